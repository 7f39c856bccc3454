// SPDX-License-Identifier: Apache-2.0
#include "face_detectors.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>

#include <algorithm>
#include <fstream>
#include <stdexcept>

namespace skr::vision {
namespace {

void requireReadable(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in || in.peek() == std::ifstream::traits_type::eof()) {
    throw std::runtime_error(std::string("cannot read ") + what + " file '" + path + "'");
  }
}

// Detection runs on a copy scaled down to detect_width; boxes are scaled back.
double detectScale(const cv::Mat& image, int detect_width) {
  if (detect_width <= 0 || image.cols <= detect_width) return 1.0;
  return static_cast<double>(detect_width) / image.cols;
}

cv::Rect scaleBack(const cv::Rect2d& r, double scale, const cv::Size& frame) {
  const cv::Rect box(cvRound(r.x / scale), cvRound(r.y / scale), cvRound(r.width / scale),
                     cvRound(r.height / scale));
  return box & cv::Rect(0, 0, frame.width, frame.height);
}

class CascadeDetector final : public FaceDetector {
 public:
  explicit CascadeDetector(const FaceParams& p) : p_(p) {
    requireReadable(p.cascade, "cascade");
    bool loaded = false;
    try {
      loaded = cascade_.load(p.cascade);
    } catch (const cv::Exception&) {  // not XML/YAML at all
    }
    if (!loaded) throw std::runtime_error("'" + p.cascade + "' is not an OpenCV cascade file");
  }

  std::vector<Face> detect(const cv::Mat& grey) override {
    const double scale = detectScale(grey, p_.detect_width);
    cv::Mat small;
    if (scale < 1.0) {
      cv::resize(grey, small, cv::Size(), scale, scale, cv::INTER_AREA);
    } else {
      small = grey;
    }
    cv::equalizeHist(small, small);
    std::vector<cv::Rect> boxes;
    std::vector<int> neighbours;
    const int min_side = std::max(1, cvRound(p_.min_size * scale));
    cascade_.detectMultiScale(small, boxes, neighbours, p_.scale_factor, p_.min_neighbors, 0,
                              cv::Size(min_side, min_side));
    std::vector<Face> faces;
    const double k = std::max(1, p_.min_neighbors);
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      // More merged candidates, more confidence: 0.5 at the min_neighbors threshold.
      const double n = i < neighbours.size() ? neighbours[i] : k;
      faces.push_back({scaleBack(boxes[i], scale, grey.size()), n / (n + k)});
    }
    return faces;
  }
  [[nodiscard]] bool wantsColour() const noexcept override { return false; }

 private:
  FaceParams p_;
  cv::CascadeClassifier cascade_;
};

class YuNetDetector final : public FaceDetector {
 public:
  explicit YuNetDetector(const FaceParams& p) : p_(p) {
    requireReadable(p.model, "model");
    try {
      net_ = cv::FaceDetectorYN::create(p.model, "", cv::Size(320, 320),
                                        static_cast<float>(p.score_threshold),
                                        static_cast<float>(p.nms_threshold), p.top_k);
    } catch (const cv::Exception& e) {
      throw std::runtime_error("'" + p.model + "' is not a YuNet ONNX model (" + e.err + ")");
    }
    if (net_.empty()) throw std::runtime_error("'" + p.model + "' could not be loaded");
  }

  std::vector<Face> detect(const cv::Mat& bgr) override {
    const double scale = detectScale(bgr, p_.detect_width);
    cv::Mat small;
    if (scale < 1.0) {
      cv::resize(bgr, small, cv::Size(), scale, scale, cv::INTER_AREA);
    } else {
      small = bgr;
    }
    if (small.size() != input_size_) {
      input_size_ = small.size();
      net_->setInputSize(input_size_);
    }
    cv::Mat found;  // one row per face: x, y, w, h, 5 landmarks (x, y), score
    net_->detect(small, found);
    std::vector<Face> faces;
    for (int r = 0; r < found.rows; ++r) {
      const float* row = found.ptr<float>(r);
      const cv::Rect2d box(row[0], row[1], row[2], row[3]);
      if (std::min(box.width, box.height) / scale < p_.min_size) continue;
      faces.push_back({scaleBack(box, scale, bgr.size()), row[14]});
    }
    return faces;
  }
  [[nodiscard]] bool wantsColour() const noexcept override { return true; }

 private:
  FaceParams p_;
  cv::Ptr<cv::FaceDetectorYN> net_;
  cv::Size input_size_;
};

}  // namespace

std::unique_ptr<FaceDetector> makeFaceDetector(const FaceParams& params) {
  if (!params.model.empty()) return std::make_unique<YuNetDetector>(params);
  return std::make_unique<CascadeDetector>(params);
}

}  // namespace skr::vision
