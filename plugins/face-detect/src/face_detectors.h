// SPDX-License-Identifier: Apache-2.0
// The two face detectors of face-detect. Each instance belongs to one worker thread.
#pragma once

#include <opencv2/core.hpp>

#include <memory>
#include <string>
#include <vector>

namespace skr::vision {

struct Face {
  cv::Rect box;  // pixels of the analysed frame
  double score;  // 0..1
};

struct FaceParams {
  std::string cascade;  // cascade file (used when model is empty)
  std::string model;    // YuNet ONNX file
  double scale_factor = 1.2;
  int min_neighbors = 3;
  int min_size = 40;             // smallest face, pixels of the frame
  int detect_width = 320;        // frames wider than this are scaled down for detection; 0: never
  double score_threshold = 0.6;  // YuNet
  double nms_threshold = 0.3;    // YuNet
  int top_k = 50;                // YuNet
};

class FaceDetector {
 public:
  virtual ~FaceDetector() = default;
  // `image` is grey (cascade) or BGR (YuNet), as wantsColour() says.
  virtual std::vector<Face> detect(const cv::Mat& image) = 0;
  [[nodiscard]] virtual bool wantsColour() const noexcept = 0;
};

// The detector the params name. Throws std::runtime_error with a reason when the cascade or
// model file cannot be loaded.
std::unique_ptr<FaceDetector> makeFaceDetector(const FaceParams& params);

}  // namespace skr::vision
