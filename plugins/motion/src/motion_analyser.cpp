// SPDX-License-Identifier: Apache-2.0
#include "motion_analyser.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <utility>

namespace skr::vision {

MotionAnalyser::MotionAnalyser(MotionParams params) : p_(std::move(params)) {
  if (p_.method == "mog2") {
    mog2_ = cv::createBackgroundSubtractorMOG2(p_.history, p_.threshold, false);
  }
}

MotionResult MotionAnalyser::analyse(const cv::Mat& grey) {
  const double scale = p_.process_width > 0 && grey.cols > p_.process_width
                           ? static_cast<double>(p_.process_width) / grey.cols
                           : 1.0;
  cv::Mat small;
  if (scale < 1.0) {
    cv::resize(grey, small, cv::Size(), scale, scale, cv::INTER_AREA);
  } else {
    small = grey.clone();
  }
  cv::GaussianBlur(small, small, cv::Size(5, 5), 0);

  MotionResult result;
  cv::Mat mask;
  if (mog2_) {
    mog2_->apply(small, mask);
  } else {
    if (previous_.size() != small.size()) {
      previous_ = small;
      return result;
    }
    cv::absdiff(small, previous_, mask);
    cv::threshold(mask, mask, p_.threshold, 255, cv::THRESH_BINARY);
    previous_ = small;
  }
  // Join the pieces of one moving body (a person's limbs) into one region.
  cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7)));

  const int moving = cv::countNonZero(mask);
  result.amount = static_cast<double>(moving) / static_cast<double>(mask.total());
  if (result.amount >= p_.min_amount && moving > 0) {
    const cv::Moments m = cv::moments(mask, true);
    result.center = cv::Point2d(m.m10 / m.m00 / scale, m.m01 / m.m00 / scale);
  }
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  const cv::Rect frame(0, 0, grey.cols, grey.rows);
  for (const auto& c : contours) {
    const cv::Rect r = cv::boundingRect(c);
    const cv::Rect box = cv::Rect(cvRound(r.x / scale), cvRound(r.y / scale),
                                  cvRound(r.width / scale), cvRound(r.height / scale)) &
                         frame;
    if (box.area() >= p_.min_area) result.regions.push_back(box);
  }
  std::sort(result.regions.begin(), result.regions.end(),
            [](const cv::Rect& a, const cv::Rect& b) { return a.area() > b.area(); });
  return result;
}

}  // namespace skr::vision
