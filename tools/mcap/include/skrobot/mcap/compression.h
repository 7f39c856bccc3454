// SPDX-License-Identifier: Apache-2.0
// Chunk compression: zstd and lz4 (the LZ4 frame format), as MCAP names them.
#pragma once

#include <skrobot/result.hpp>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::mcap {

enum class Compression { none, zstd, lz4 };

// "" , "zstd", "lz4": the chunk's `compression` field.
[[nodiscard]] std::string_view compressionName(Compression c) noexcept;
// Errc::unsupported for another name.
[[nodiscard]] Result<Compression> compressionFromName(std::string_view name);

// Appends `data` compressed to `out` (replaces its content). Errc::internal when the library fails.
[[nodiscard]] Result<void> compress(Compression c, std::string_view data, std::string& out);
// Decompresses into `out`, which must come out exactly `uncompressed_size` bytes; the caller
// checks that size against its limit before calling (it is allocated up front).
// Errc::parse_error for a damaged or mis-sized stream.
[[nodiscard]] Result<void> decompress(Compression c, std::string_view data,
                                      uint64_t uncompressed_size, std::string& out);

}  // namespace skr::mcap
