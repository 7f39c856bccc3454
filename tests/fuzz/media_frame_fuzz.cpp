// SPDX-License-Identifier: Apache-2.0
// Fuzz target: the media frame header parser. Whatever it accepts must re-encode to the same
// header fields and keep its payload inside the input; a raw frame's payload must be exactly
// rawPayloadBytes(width, height), and makeRawFrame must make the same message again.
#include <skrobot/media_frame.hpp>

#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  auto frame = skr::media::parseFrame(in);
  if (!frame) return 0;
  if (frame->payload.data() < in.data() ||
      frame->payload.data() + frame->payload.size() > in.data() + in.size()) {
    std::abort();
  }
  const std::string again = skr::media::makeFrame(frame->header, frame->payload);
  auto back = skr::media::parseFrame(again);
  if (!back || back->header.seq != frame->header.seq ||
      back->header.capture_ns != frame->header.capture_ns || back->payload != frame->payload) {
    std::abort();
  }
  (void)skr::media::sampleCount(*back);
  const auto* info = skr::media::encodingInfo(frame->header.format);
  if (info == nullptr) std::abort();
  if (skr::media::isRaw(*info)) {
    const auto& h = frame->header;
    if (frame->payload.size() != skr::media::rawPayloadBytes(*info, h.width, h.height)) {
      std::abort();
    }
    auto raw =
        skr::media::makeRawFrame(h.format, h.width, h.height, frame->payload, h.seq, h.capture_ns);
    if (!raw || (h.flags == 0 && *raw != again)) std::abort();
  }
  return 0;
}
