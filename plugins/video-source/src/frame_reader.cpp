// SPDX-License-Identifier: Apache-2.0
#include "frame_reader.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cctype>
#include <filesystem>
#include <stdexcept>
#include <vector>

namespace skr::vision {
namespace {

bool allDigits(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (std::isdigit(static_cast<unsigned char>(c)) == 0) return false;
  }
  return true;
}

}  // namespace

FrameReader::FrameReader(const SourceParams& params) : p_(params) {
  open();
}

void FrameReader::open() {
  bool opened = false;
  if (isFile()) {
    if (p_.file.find('%') == std::string::npos && !std::filesystem::exists(p_.file)) {
      throw std::runtime_error("no such file '" + p_.file + "'");
    }
    // FFmpeg for video files, OpenCV's image-sequence reader for patterns such as img_%03d.jpg.
    // Not CAP_ANY: it also probes camera back ends (FireWire through libusb) for a file.
    opened = capture_.open(p_.file, cv::CAP_FFMPEG) ||
             (p_.file.find('%') != std::string::npos && capture_.open(p_.file, cv::CAP_IMAGES));
  } else if (allDigits(p_.device)) {
    opened = capture_.open(std::stoi(p_.device), cv::CAP_V4L2);
  } else {
    opened = capture_.open(p_.device, cv::CAP_V4L2);
  }
  if (!opened) {
    throw std::runtime_error("OpenCV cannot open '" + (isFile() ? p_.file : p_.device) + "'");
  }
  if (!isFile()) {
    // Ask the camera for the wanted size and rate; frames are resized anyway.
    capture_.set(cv::CAP_PROP_FRAME_WIDTH, p_.width);
    capture_.set(cv::CAP_PROP_FRAME_HEIGHT, p_.height);
    capture_.set(cv::CAP_PROP_FPS, p_.fps);
  }
}

std::string FrameReader::next(bool& looped) {
  looped = false;
  if (!capture_.read(frame_) || frame_.empty()) {
    if (!isFile() || !p_.loop) return {};
    // Rewind; some containers cannot seek, so reopen when that fails.
    if (!capture_.set(cv::CAP_PROP_POS_FRAMES, 0) || !capture_.read(frame_) || frame_.empty()) {
      capture_.release();
      open();
      if (!capture_.read(frame_) || frame_.empty()) return {};
    }
    looped = true;
  }
  if (frame_.cols != p_.width || frame_.rows != p_.height) {
    cv::resize(frame_, sized_, cv::Size(p_.width, p_.height), 0, 0, cv::INTER_AREA);
  } else {
    sized_ = frame_;
  }
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", sized_, jpeg, {cv::IMWRITE_JPEG_QUALITY, p_.jpeg_quality});
  return {jpeg.begin(), jpeg.end()};
}

}  // namespace skr::vision
