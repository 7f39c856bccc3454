// SPDX-License-Identifier: Apache-2.0
// Decoding of video media frames into OpenCV images (any thread).
#pragma once

#include <skrobot/vision/pipeline.h>
#include <skrobot/media_frame.hpp>

#include <opencv2/core.hpp>

#include <string_view>

namespace skr::vision {

// The frame's pixels as `pixels` asks: a JPEG is decoded (grey decoding skips the chroma planes),
// a Y8 frame is copied. An empty Mat when the payload cannot be decoded (a corrupt JPEG) or the
// format is not video.
cv::Mat decodeFrame(const media::FrameHeader& header, std::string_view payload, Pixels pixels);

}  // namespace skr::vision
