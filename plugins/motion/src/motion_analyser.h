// SPDX-License-Identifier: Apache-2.0
// Motion in a sequence of grey frames: frame differencing (default) or MOG2 background
// subtraction. One instance per worker; it keeps the previous frame or the background model.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/video/background_segm.hpp>

#include <optional>
#include <string>
#include <vector>

namespace skr::vision {

struct MotionParams {
  std::string method = "diff";  // "diff" or "mog2"
  int process_width = 320;      // frames are scaled to this width first; 0: full size
  int threshold = 25;           // grey-level change that counts as motion (diff); MOG2 varThreshold
  int min_area = 100;           // smallest region, in pixels of the frame
  double min_amount = 0.002;    // below this fraction of moving pixels, no centre
  int history = 100;            // MOG2 frames of history
};

struct MotionResult {
  double amount = 0;                  // fraction of moving pixels, 0..1
  std::optional<cv::Point2d> center;  // centroid of the moving pixels, pixels of the frame
  std::vector<cv::Rect> regions;      // pixels of the frame, largest first
};

class MotionAnalyser {
 public:
  explicit MotionAnalyser(MotionParams params);
  // `grey` is CV_8UC1. The first frame (or one of another size) only primes the model.
  MotionResult analyse(const cv::Mat& grey);

 private:
  MotionParams p_;
  cv::Mat previous_;
  cv::Ptr<cv::BackgroundSubtractorMOG2> mog2_;
};

}  // namespace skr::vision
