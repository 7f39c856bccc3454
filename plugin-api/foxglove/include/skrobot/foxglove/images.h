// SPDX-License-Identifier: Apache-2.0
// Media frames (skrobot/media_frame.hpp) as Foxglove's image messages (JSON), and back: what
// foxglove-bridge sends (docs/foxglove.md) and flowctl record writes and play reads
// (docs/recording.md). Pure functions; any thread.
//
// Besides the fields of foxglove.RawImage and foxglove.CompressedImage, a message carries what
// its frame needs to be made again byte for byte: `seq` (the header's seq), for a JPEG `width` and
// `height`, and for an i420 frame (sent as nv12) `frame_encoding` "i420". Readers of the Foxglove
// schemas ignore them.
#pragma once

#include <skrobot/result.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace skr::foxglove {

inline constexpr std::string_view kCompressedImage = "foxglove.CompressedImage";
inline constexpr std::string_view kRawImage = "foxglove.RawImage";

// JSON schema of foxglove.Time, and of the two image messages (the field names and required lists
// of @foxglove/schemas 2.1.0; tests/foxglove checks them against it).
[[nodiscard]] std::string_view timeSchema();
[[nodiscard]] std::string compressedImageSchema();
[[nodiscard]] std::string rawImageSchema();

// A converted message and its log time (ns since the epoch; 0: the receipt time).
struct Converted {
  std::string json;
  std::uint64_t time_ns = 0;
};

// A media frame holding a JPEG as foxglove.CompressedImage JSON; nullopt for anything else.
[[nodiscard]] std::optional<Converted> compressedImage(std::string_view message,
                                                       const std::string& frame_id);
// A media frame of raw pixels as foxglove.RawImage JSON (encodings as Foxglove names them: rgb8,
// bgr8, rgba8, bgra8, mono8, mono16, nv12; i420 is sent as nv12, its chroma planes interleaved);
// nullopt for anything else.
[[nodiscard]] std::optional<Converted> rawImage(std::string_view message,
                                                const std::string& frame_id);
// Whether a channel of this `encoding` property is shown as foxglove.RawImage.
[[nodiscard]] bool isRawImageEncoding(std::string_view encoding);

// The media frame that rawImage or compressedImage made `json` from, byte for byte (with the
// 32-byte header; a negative capture time comes back as 0). Errc::parse_error, with what is
// wrong, for anything else.
[[nodiscard]] Result<std::string> mediaFrameOf(std::string_view json);

}  // namespace skr::foxglove
