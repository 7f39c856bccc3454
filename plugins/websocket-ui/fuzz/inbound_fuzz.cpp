// SPDX-License-Identifier: Apache-2.0
// Fuzz target: parseInbound on text and binary messages. The first byte picks the kind.
#include "browser_protocol.h"

#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <variant>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool binary = (data[0] & 1) != 0;
  const std::string_view msg(reinterpret_cast<const char*>(data + 1), size - 1);
  const skr::wsui::InboundLimits limits;
  const auto in = skr::wsui::parseInbound(binary, msg, limits);
  if (const auto* cam = std::get_if<skr::wsui::CameraFrame>(&in)) {
    if (cam->jpeg.data() < msg.data() ||
        cam->jpeg.data() + cam->jpeg.size() > msg.data() + msg.size()) {
      std::abort();
    }
  }
  if (const auto* say = std::get_if<skr::wsui::Say>(&in)) {
    if (say->text.empty() || say->text.size() > limits.max_say_chars) std::abort();
  }
  return 0;
}
