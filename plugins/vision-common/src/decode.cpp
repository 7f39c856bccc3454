// SPDX-License-Identifier: Apache-2.0
#include <skrobot/vision/decode.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace skr::vision {
namespace {

cv::Mat convert(const cv::Mat& in, int code) {
  cv::Mat out;
  cv::cvtColor(in, out, code);
  return out;
}

}  // namespace

cv::Mat decodeFrame(const media::FrameHeader& header, std::string_view payload, Pixels pixels) {
  const int w = header.width;
  const int h = header.height;
  auto* data = const_cast<char*>(payload.data());  // read only: every path below copies
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
      // parseFrame checked every raw payload's size against the width and height.
      const cv::Mat grey(h, w, CV_8UC1, data);
      if (pixels == Pixels::grey) return grey.clone();
      return convert(grey, cv::COLOR_GRAY2BGR);
    }
    case media::Format::mono16: {
      const cv::Mat deep(h, w, CV_16UC1, data);  // little-endian, as this host
      cv::Mat grey;
      deep.convertTo(grey, CV_8U, 1.0 / 256);
      if (pixels == Pixels::grey) return grey;
      return convert(grey, cv::COLOR_GRAY2BGR);
    }
    case media::Format::bgr8: {
      const cv::Mat bgr(h, w, CV_8UC3, data);
      return pixels == Pixels::grey ? convert(bgr, cv::COLOR_BGR2GRAY) : bgr.clone();
    }
    case media::Format::rgb8:
      return convert(cv::Mat(h, w, CV_8UC3, data),
                     pixels == Pixels::grey ? cv::COLOR_RGB2GRAY : cv::COLOR_RGB2BGR);
    case media::Format::rgba8:
      return convert(cv::Mat(h, w, CV_8UC4, data),
                     pixels == Pixels::grey ? cv::COLOR_RGBA2GRAY : cv::COLOR_RGBA2BGR);
    case media::Format::bgra8:
      return convert(cv::Mat(h, w, CV_8UC4, data),
                     pixels == Pixels::grey ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGRA2BGR);
    case media::Format::nv12:
    case media::Format::i420: {
      // The Y plane (h rows) is the grey image; the chroma planes follow it.
      const cv::Mat yuv(h * 3 / 2, w, CV_8UC1, data);
      if (pixels == Pixels::grey) return yuv.rowRange(0, h).clone();
      return convert(yuv, header.format == media::Format::nv12 ? cv::COLOR_YUV2BGR_NV12
                                                               : cv::COLOR_YUV2BGR_I420);
    }
    case media::Format::pcm_s16le:
      break;
  }
  return {};
}

}  // namespace skr::vision
