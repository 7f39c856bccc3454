// SPDX-License-Identifier: Apache-2.0
// Frames from a video file (looped) or a camera, resized and JPEG-encoded. One thread uses it.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include <string>

namespace skr::vision {

struct SourceParams {
  std::string file;    // a video file (or an image sequence pattern such as img_%03d.png)
  std::string device;  // a V4L2 device path or index, when no file
  int width = 640;
  int height = 360;
  double fps = 15;
  bool loop = true;
  int jpeg_quality = 80;
};

class FrameReader {
 public:
  // Opens the source; throws std::runtime_error with a reason when it cannot.
  explicit FrameReader(const SourceParams& params);

  // The next frame as a JPEG of width x height. Empty at the end of a file that does not loop,
  // or when a camera gives nothing. `looped` is set when a file started again.
  std::string next(bool& looped);
  [[nodiscard]] bool isFile() const noexcept { return !p_.file.empty(); }

 private:
  void open();

  SourceParams p_;
  cv::VideoCapture capture_;
  cv::Mat frame_, sized_;
};

}  // namespace skr::vision
