// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as what a WebSocket peer sends, through the runtime's frame
// reader (runtime/internal/ws_frame.h) as a server (masked frames expected) and as a client:
// payload never outgrows the input, a control frame is at most 125 bytes, a refusal carries a
// close code the layer sends, and reading the bytes in two pieces (split where the first byte
// says) delivers exactly what reading them whole does.
#include "ws_frame.h"

#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

using namespace skr::flow;

namespace {

struct Sink final : ws::FrameReader::Sink {
  std::string data;
  std::string controls;  // opcode byte + payload of each
  char buf[5];           // small: payloads cross many room() calls
  std::span<char> room() override { return {buf, sizeof buf}; }
  bool payload(size_t n) override {
    if (n == 0 || n > sizeof buf) std::abort();
    data.append(buf, n);
    return true;
  }
  bool control(ws::Opcode op, std::string_view p) override {
    if (p.size() > ws::kMaxControlPayload) std::abort();
    if (op != ws::Opcode::ping && op != ws::Opcode::pong && op != ws::Opcode::close) std::abort();
    controls.push_back(static_cast<char>(op));
    controls.append(p);
    return true;
  }
};

void check(bool server, std::string_view d, size_t split) {
  ws::FrameReader whole(server);
  Sink a;
  const size_t used = whole.feed(d, a);
  if (used > d.size() || a.data.size() > d.size()) std::abort();
  if (!whole.failure() && used != d.size()) std::abort();
  if (const auto& f = whole.failure()) {
    if (f->code != ws::kCloseProtocolError && f->code != ws::kCloseUnsupportedData &&
        f->code != ws::kCloseInvalidPayload) {
      std::abort();
    }
  }
  ws::FrameReader pieces(server);
  Sink b;
  const size_t first = pieces.feed(d.substr(0, split), b);
  if (!pieces.failure() && first == split) pieces.feed(d.substr(split), b);
  if (a.data != b.data || a.controls != b.controls ||
      whole.failure().has_value() != pieces.failure().has_value()) {
    std::abort();
  }
  if (whole.failure() && whole.failure()->code != pieces.failure()->code) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view d(reinterpret_cast<const char*>(data), size);
  const size_t split = size == 0 ? 0 : data[0] % (size + 1);
  check(true, d, split);
  check(false, d, split);
  return 0;
}
