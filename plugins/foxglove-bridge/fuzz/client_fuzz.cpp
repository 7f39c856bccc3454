// SPDX-License-Identifier: Apache-2.0
// Fuzz target: decodeClientMessage on text and binary client messages, and the conversions of
// publishers' messages. The first byte picks: bit 0 binary, bits 1-2 what is fed.
#include "foxglove_convert.h"
#include "foxglove_protocol.h"

#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <variant>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool binary = (data[0] & 1) != 0;
  const int what = (data[0] >> 1) & 3;
  const std::string_view msg(reinterpret_cast<const char*>(data + 1), size - 1);
  namespace fg = skr::foxglove;
  if (what == 0) {
    fg::DecodeLimits limits;
    limits.max_items = 64;
    const auto m = fg::decodeClientMessage(binary, msg, limits);
    if (!m) return 0;
    if (const auto* call = std::get_if<fg::ServiceCallRequest>(&*m)) {
      if (call->encoding.size() > limits.max_name_bytes) std::abort();
      if (call->encoding.size() + call->data.size() + 13 != msg.size()) std::abort();
    }
    if (const auto* s = std::get_if<fg::Subscribe>(&*m)) {
      if (s->subscriptions.size() > limits.max_items) std::abort();
    }
    return 0;
  }
  if (what == 1) {
    (void)fg::compressedImage(msg, "camera");
  } else if (what == 2) {
    (void)fg::imageAnnotations(msg);
  } else {
    (void)fg::jointPositions(msg, {"HeadYaw", "HeadPitch"});
  }
  return 0;
}
