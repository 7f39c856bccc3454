// SPDX-License-Identifier: Apache-2.0
#include <skrobot/vision/decode.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace skr::vision {

cv::Mat decodeFrame(const media::FrameHeader& header, std::string_view payload, Pixels pixels) {
  switch (header.format) {
    case media::Format::jpeg: {
      if (payload.empty()) return {};
      const cv::Mat bytes(1, static_cast<int>(payload.size()), CV_8UC1,
                          const_cast<char*>(payload.data()));
      try {
        return cv::imdecode(bytes,
                            pixels == Pixels::grey ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
      } catch (const cv::Exception&) {  // some corrupt streams throw instead of returning empty
        return {};
      }
    }
    case media::Format::y8: {
      // parseFrame checked that the payload is width * height bytes.
      const cv::Mat grey(header.height, header.width, CV_8UC1, const_cast<char*>(payload.data()));
      if (pixels == Pixels::grey) return grey.clone();
      cv::Mat bgr;
      cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
      return bgr;
    }
    case media::Format::pcm_s16le:
      break;
  }
  return {};
}

}  // namespace skr::vision
