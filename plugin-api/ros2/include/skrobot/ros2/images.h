// SPDX-License-Identifier: Apache-2.0
// sensor_msgs/msg/Image and sensor_msgs/msg/CompressedImage as the hub's media frames
// (skrobot/media_frame.hpp), and back: what ros2-bridge's `media` items convert with
// (docs/ros2.md, "Images"). The two layouts are fixed, so the samples are read and written here
// directly (one copy of the pixels each way), not through the registry; ros2_image_fuzz runs both
// directions. Any thread.
//
// Image <-> a raw frame of rgb8, bgr8, rgba8, bgra8, mono8 or mono16 (the same names in both
// vocabularies); CompressedImage <-> a JPEG frame (`format` "jpeg"). Stamps: the header's stamp is
// the frame's capture time and back (a frame without one, or a zero stamp, takes `now_ns`). The
// header's frame_id has no place in a media frame: it is set on export and dropped on import.
#pragma once

#include <skrobot/result.hpp>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::ros2 {

inline constexpr std::string_view kImageType = "sensor_msgs/msg/Image";
inline constexpr std::string_view kCompressedImageType = "sensor_msgs/msg/CompressedImage";

// Whether `type` is one of the two above.
[[nodiscard]] bool isImageType(std::string_view type);

// The media frame `frame` as a little-endian CDR sample of `type` (one of the two above).
// Errc::invalid_argument, saying why: not a media frame, or a format `type` does not carry (a
// JPEG as Image, raw pixels as CompressedImage, nv12, i420, audio).
[[nodiscard]] Result<std::string> frameToImage(std::string_view type, std::string_view frame,
                                               std::string_view frame_id, std::int64_t now_ns);

// The CDR sample `cdr` of `type` as a media frame numbered `seq`. Image: a padded `step` is
// repacked and a big-endian mono16 swapped; width and height fit a frame's 16 bits.
// CompressedImage: a JPEG, its size read from its own frame header. Errc::parse_error for a
// sample that is not one of `type` (naming the field and the offset), Errc::unsupported for
// pixels the hub has no encoding for (yuv422, 32FC1, png, ...).
[[nodiscard]] Result<std::string> imageToFrame(std::string_view type, std::string_view cdr,
                                               std::uint64_t seq, std::int64_t now_ns);

}  // namespace skr::ros2
