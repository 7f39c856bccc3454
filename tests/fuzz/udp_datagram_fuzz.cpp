// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as a datagram on the hub's UDP port, through its reader
// (core/src/flow/udp_wire.h) as the port reads it: every parse stays inside the datagram, a
// DATA that is read back is what the writer wrote, and the replay window never accepts a number
// twice.
#include "udp_wire.h"

#include <cstdint>
#include <cstdlib>
#include <set>
#include <string_view>

using namespace skr::flow;

namespace {

bool inside(std::string_view part, std::string_view whole) {
  return part.empty() ||
         (part.data() >= whole.data() && part.data() + part.size() <= whole.data() + whole.size());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view d(reinterpret_cast<const char*>(data), size);
  const udp::Key key{1, 2, 3};
  (void)udp::typeOf(d);
  if (auto h = udp::parseHello(d)) {
    if (size < udp::kHelloBytes || !inside(h->user, d) || h->user.size() > udp::kMaxUser) {
      std::abort();
    }
  }
  if (auto o = udp::parseOpen(d)) {
    if (!inside(o->user, d) || !inside(o->signed_part, d) || o->signed_part.size() + 16 != size) {
      std::abort();
    }
    (void)udp::mac128(key, o->signed_part);
  }
  if (auto m = udp::parseNumbered(d)) {
    if (!inside(m->frame, d) || m->signed_part.size() + 8 != size ||
        m->frame.size() + udp::kDataOverhead != size) {
      std::abort();
    }
    (void)udp::wholeFrame(m->frame);
    const std::string again = udp::makeNumbered(m->type, key, m->session, m->seq, m->frame);
    auto back = udp::parseNumbered(again);
    if (!back || back->frame != m->frame || back->seq != m->seq ||
        udp::mac64(key, back->signed_part) != back->mac) {
      std::abort();
    }
  }
  // The bytes as sequence numbers: none accepted twice while inside the window.
  udp::ReplayWindow w;
  uint64_t lost = 0;
  std::set<uint32_t> seen;
  for (size_t i = 0; i + 2 <= size; i += 2) {
    const uint32_t seq = static_cast<uint32_t>(data[i]) | static_cast<uint32_t>(data[i + 1]) << 8;
    const bool fresh = w.take(seq, lost) != udp::ReplayWindow::Verdict::replayed;
    if (fresh && (seq == 0 || !seen.insert(seq).second)) std::abort();
  }
  return 0;
}
