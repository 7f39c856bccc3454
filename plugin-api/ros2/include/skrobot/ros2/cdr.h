// SPDX-License-Identifier: Apache-2.0
// ROS 2 messages as CDR and as JSON, from their definitions (definitions.h), without generated
// code: what ros2-bridge converts between a `cdr` sample and a `json` channel, what flowctl shows
// of a `cdr` channel, and what the fuzz target ros2_cdr_fuzz runs.
//
// CDR here is what ROS 2 writes through Fast DDS and Cyclone DDS: a 4-byte encapsulation header
// (00 01 = little-endian CDR, 00 00 = big-endian; two option bytes), then the fields in order,
// each primitive aligned to its size (8 at most) from the end of that header (at most 3 bytes of
// padding may follow the last field; more is an error); a string is a
// uint32 length counting its NUL, its bytes and the NUL; a sequence (T[], T[<=N]) a uint32 count
// and its elements; a fixed array (T[N]) its N elements; a message without fields one uint8.
// Writing is always little-endian. wstring fields are refused (ROS 2's layout of them differs
// between vendors).
//
// JSON: a message is an object with every field; integers are numbers (a 64-bit one exact in
// Json::Value, JavaScript reads it as a double), floats numbers (NaN and infinities, which JSON
// lacks, are refused when written and read as null), byte and uint8 arrays arrays of numbers.
// jsonToCdr takes a field left out as its default (the definition's, or zero and empty) and
// refuses a field the definition lacks, naming its path.
#pragma once

#include <skrobot/ros2/definitions.h>
#include <skrobot/result.hpp>

#include <json/value.h>

#include <cstddef>
#include <string>
#include <string_view>

namespace skr::ros2 {

inline constexpr std::size_t kEncapsulationBytes = 4;
// How deep messages nest, at most (a definition that nests deeper is refused).
inline constexpr int kMaxDepth = 32;

// The sample `bytes` of `type` ("pkg/msg/Name") as JSON. Errc::parse_error naming the field's
// path and the byte where it went wrong; Errc::not_found for a type the registry lacks.
[[nodiscard]] Result<Json::Value> cdrToJson(const Registry& registry, std::string_view type,
                                            std::string_view bytes);
// Whether `bytes` is a sample of `type`, as cdrToJson reads it (the same errors), without
// building its JSON: what ros2-bridge checks a `cdr` sample with (a byte array is skipped whole).
[[nodiscard]] Result<void> validate(const Registry& registry, std::string_view type,
                                    std::string_view bytes);
// `value` as a little-endian CDR sample of `type`. Errc::invalid_argument naming the path.
[[nodiscard]] Result<std::string> jsonToCdr(const Registry& registry, std::string_view type,
                                            const Json::Value& value);

}  // namespace skr::ros2
