// SPDX-License-Identifier: Apache-2.0
// QR codes and barcodes in a grey image, with zbar. One instance per worker thread.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace zbar {
class ImageScanner;
}

namespace skr::vision {

struct Code {
  std::string type;  // zbar's name: "QR-Code", "EAN-13", "CODE-128", ...
  std::string text;
  // QR: as zbar reports them (top-left, bottom-left, bottom-right, top-right of the upright
  // symbol); barcodes: their bounding box in the same order.
  std::array<cv::Point, 4> corners;
};

// Which symbologies a scanner decodes (config "types"; docs/vision.md lists them).
enum class CodeTypes {
  common,  // QR codes and the common retail and industrial barcodes
  qr,      // QR codes only
  all,     // everything zbar decodes, the EAN-2/EAN-5 add-ons and DataBar included
};
// The choices of config "types", as the host checks them ("common|qr|all").
inline constexpr const char* kCodeTypesChoices = "common|qr|all";
// `name` is one of kCodeTypesChoices; nullopt otherwise.
std::optional<CodeTypes> codeTypesFromName(std::string_view name);

class CodeScanner {
 public:
  // Decodes `types`; scans every `density`-th row and column (1: all of them).
  CodeScanner(CodeTypes types, int density);
  ~CodeScanner();
  CodeScanner(const CodeScanner&) = delete;
  CodeScanner& operator=(const CodeScanner&) = delete;

  // `grey` is CV_8UC1. Codes sorted by type then text.
  std::vector<Code> scan(const cv::Mat& grey);

 private:
  std::unique_ptr<zbar::ImageScanner> scanner_;
};

// The set of codes as one string, to tell when it changes.
std::string codeSetKey(const std::vector<Code>& codes);

}  // namespace skr::vision
