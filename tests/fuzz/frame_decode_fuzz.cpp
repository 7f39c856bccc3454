// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as a FlowProtocol stream. The splitter must never read past
// the input or accept an over-limit length; every frame body is decoded as each message of its
// code, and what decodes must re-encode to bytes that decode to the same message again. The same
// bytes received in pieces through FrameInput (what the hub's connections and the satellite's
// link read into) give the same frames and stop at the same bad length.
#include "frame_input.h"

#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/message_table.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

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

using Frames = std::vector<std::pair<uint8_t, std::string>>;

// Feeds [data, size) in pieces of `piece` bytes; the frames must be `expected`, and a bad length
// must come exactly where the splitter found one (`bad`).
void throughFrameInput(const uint8_t* data, size_t size, size_t piece, uint32_t limit,
                       const Frames& expected, bool bad) {
  skr::flow::FrameInput input(limit);
  size_t fed = 0, seen = 0;
  bool stopped = false;
  while (fed < size && !stopped) {
    const auto room = input.room();
    if (room.empty()) std::abort();
    const size_t n = std::min({room.size(), piece, size - fed});
    std::memcpy(room.data(), data + fed, n);
    input.commit(n);
    fed += n;
    for (;;) {
      const auto f = input.peek();
      if (f.status == skr::flow::FrameSplitter::Status::need_more) break;
      if (f.status != skr::flow::FrameSplitter::Status::frame) {
        if (!bad || seen != expected.size()) std::abort();
        stopped = true;
        break;
      }
      if (seen >= expected.size() || expected[seen].first != f.code ||
          expected[seen].second != f.body) {
        std::abort();
      }
      ++seen;
      input.consume(f);
    }
    input.settle();
  }
  if (seen != expected.size() || (bad && !stopped)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  constexpr uint32_t kLimit = 1 << 20;
  const skr::flow::FrameSplitter splitter(kLimit);
  size_t pos = 0;
  Frames frames;
  bool bad = false;
  while (pos < size) {
    const auto n = splitter.next(data + pos, size - pos);
    if (n.status != skr::flow::FrameSplitter::Status::frame) {
      bad = n.status != skr::flow::FrameSplitter::Status::need_more;
      if (n.status == skr::flow::FrameSplitter::Status::need_more && n.wanted > 0 &&
          n.wanted <= size - pos) {
        std::abort();  // asked for more than it needed
      }
      break;
    }
    if (n.announced > kLimit || n.consumed > size - pos) std::abort();
    skr::flow::forEachMessage([&](auto m) { roundTrip<decltype(m)>(n.code, n.body); });
    frames.emplace_back(n.code, std::string(n.body));
    pos += n.consumed;
  }
  if (size > 0) throughFrameInput(data, size, 1 + data[0] % 97, kLimit, frames, bad);
  return 0;
}
