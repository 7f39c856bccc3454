// SPDX-License-Identifier: Apache-2.0
// Decoding of video media frames into OpenCV images (any thread).
#pragma once

#include <skrobot/vision/pipeline.h>
#include <skrobot/media_frame.hpp>

#include <opencv2/core.hpp>

#include <string_view>

namespace skr::vision {

// The frame's pixels as `pixels` asks (8-bit BGR or grey): a JPEG is decoded (grey decoding skips
// the chroma planes), a raw frame (mono8, mono16, rgb8, bgr8, rgba8, bgra8, nv12, i420) is
// converted or copied; the result never points into `payload`. The header and payload must be a
// frame parseFrame accepted (it checked raw sizes). An empty Mat when the payload cannot be
// decoded (a corrupt JPEG) or the format is not video.
cv::Mat decodeFrame(const media::FrameHeader& header, std::string_view payload, Pixels pixels);

}  // namespace skr::vision
