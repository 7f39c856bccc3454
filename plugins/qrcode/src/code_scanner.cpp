// SPDX-License-Identifier: Apache-2.0
#include "code_scanner.h"

#include <opencv2/imgproc.hpp>

#include <zbar.h>

#include <algorithm>

namespace skr::vision {
namespace {

// What "common" enables. Left out: the EAN-2 and EAN-5 add-ons, two and five digits that zbar
// also reads on their own and finds in ordinary pictures (skimage's astronaut.png in the demo's
// 640x360 camera frame reads as "EAN-2: 34"), and DataBar, whose decoder pairs halves found in
// different scan lines (opencv-doc's aero1.jpg in a camera frame at JPEG 50 reads as one).
// tests/vision/qrcode_test.cpp checks every sample picture.
constexpr zbar::zbar_symbol_type_t kCommon[] = {
    zbar::ZBAR_QRCODE,  zbar::ZBAR_EAN13,  zbar::ZBAR_EAN8,   zbar::ZBAR_UPCA, zbar::ZBAR_UPCE,
    zbar::ZBAR_CODE128, zbar::ZBAR_CODE39, zbar::ZBAR_CODE93, zbar::ZBAR_I25,  zbar::ZBAR_CODABAR,
};

}  // namespace

std::optional<CodeTypes> codeTypesFromName(std::string_view name) {
  if (name == "common") return CodeTypes::common;
  if (name == "qr") return CodeTypes::qr;
  if (name == "all") return CodeTypes::all;
  return std::nullopt;
}

CodeScanner::CodeScanner(CodeTypes types, int density)
    : scanner_(std::make_unique<zbar::ImageScanner>()) {
  // ZBAR_NONE sets every symbology at once; then the chosen ones are enabled again.
  scanner_->set_config(zbar::ZBAR_NONE, zbar::ZBAR_CFG_ENABLE, types == CodeTypes::all ? 1 : 0);
  if (types == CodeTypes::qr) {
    scanner_->set_config(zbar::ZBAR_QRCODE, zbar::ZBAR_CFG_ENABLE, 1);
  } else if (types == CodeTypes::common) {
    for (const auto t : kCommon) scanner_->set_config(t, zbar::ZBAR_CFG_ENABLE, 1);
  }
  scanner_->set_config(zbar::ZBAR_NONE, zbar::ZBAR_CFG_X_DENSITY, density);
  scanner_->set_config(zbar::ZBAR_NONE, zbar::ZBAR_CFG_Y_DENSITY, density);
}

CodeScanner::~CodeScanner() = default;

std::vector<Code> CodeScanner::scan(const cv::Mat& grey) {
  const cv::Mat pixels = grey.isContinuous() ? grey : grey.clone();
  // zbar reads the buffer in place ("Y800": 8-bit grey) and does not free it.
  zbar::Image image(static_cast<unsigned>(pixels.cols), static_cast<unsigned>(pixels.rows), "Y800",
                    pixels.data, pixels.total());
  scanner_->scan(image);
  std::vector<Code> codes;
  for (auto s = image.symbol_begin(); s != image.symbol_end(); ++s) {
    Code c;
    c.type = s->get_type_name();
    c.text = s->get_data();
    const int n = s->get_location_size();
    if (n == 4) {
      for (int i = 0; i < 4; ++i) c.corners[i] = {s->get_location_x(i), s->get_location_y(i)};
    } else {
      // A barcode's location is the points of its scan lines: report their bounding box.
      std::vector<cv::Point> points;
      for (int i = 0; i < n; ++i) points.emplace_back(s->get_location_x(i), s->get_location_y(i));
      const cv::Rect r = points.empty() ? cv::Rect() : cv::boundingRect(points);
      // In the order zbar gives a QR code's corners: top-left, bottom-left, bottom-right,
      // top-right.
      c.corners = {cv::Point(r.x, r.y), cv::Point(r.x, r.y + r.height),
                   cv::Point(r.x + r.width, r.y + r.height), cv::Point(r.x + r.width, r.y)};
    }
    codes.push_back(std::move(c));
  }
  image.set_data(nullptr, 0);
  std::sort(codes.begin(), codes.end(), [](const Code& a, const Code& b) {
    return a.type != b.type ? a.type < b.type : a.text < b.text;
  });
  return codes;
}

std::string codeSetKey(const std::vector<Code>& codes) {
  std::string key;
  for (const auto& c : codes) {
    key += c.type;
    key += '\0';
    key += std::to_string(c.text.size());
    key += ':';
    key += c.text;
  }
  return key;
}

}  // namespace skr::vision
