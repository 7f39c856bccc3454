// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as a FlowProtocol stream. The splitter must never read past
// the input or accept an over-limit length; every frame body is decoded as each message of its
// code, and what decodes must re-encode to bytes that decode to the same message again.
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/message_table.h>

#include <cstdint>
#include <cstdlib>
#include <string>

namespace {

template <class M>
void roundTrip(uint8_t code, std::string_view body) {
  if (code != static_cast<uint8_t>(M::code)) return;
  auto decoded = skr::flow::decode<M>(body);
  if (!decoded) return;
  std::string once;
  if (!skr::flow::encode(once, decoded.value())) std::abort();  // decoded fields always fit
  auto again = skr::flow::decode<M>(std::string_view(once).substr(5));
  if (!again) std::abort();
  std::string twice;
  if (!skr::flow::encode(twice, again.value()) || twice != once) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  constexpr uint32_t kLimit = 1 << 20;
  const skr::flow::FrameSplitter splitter(kLimit);
  size_t pos = 0;
  while (pos < size) {
    const auto n = splitter.next(data + pos, size - pos);
    if (n.status != skr::flow::FrameSplitter::Status::frame) {
      if (n.status == skr::flow::FrameSplitter::Status::need_more && n.wanted > 0 &&
          n.wanted <= size - pos) {
        std::abort();  // asked for more than it needed
      }
      break;
    }
    if (n.announced > kLimit || n.consumed > size - pos) std::abort();
    skr::flow::forEachMessage([&](auto m) { roundTrip<decltype(m)>(n.code, n.body); });
    pos += n.consumed;
  }
  return 0;
}
