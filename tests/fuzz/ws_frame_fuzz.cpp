// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as what a WebSocket peer sends, through the runtime's frame
// reader (runtime/internal/ws_frame.h) as a server (masked frames expected) and as a client:
// payload never outgrows the input, a control frame is at most 125 bytes, a refusal carries a
// close code the layer sends, and reading the bytes in two pieces (split where the first byte
// says) delivers exactly what reading them whole does. The same in messages mode (a module's
// subprotocol, a 64-byte limit): no message longer than the limit is ever ended, and the payload
// delivered is exactly that of the messages ended plus the one under way.
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
  std::string messages;  // messages mode: opcode byte + payload of each ended message
  size_t message_start = 0;
  uint64_t max = 0;
  char buf[5];  // small: payloads cross many room() calls
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
  bool messageEnd(ws::Opcode op) override {
    if (max == 0 || (op != ws::Opcode::text && op != ws::Opcode::binary)) std::abort();
    if (data.size() - message_start > max) std::abort();
    messages.push_back(static_cast<char>(op));
    messages.append(data, message_start);
    message_start = data.size();
    return true;
  }
};

ws::FrameReader reader(bool server, uint64_t max) {
  return max == 0 ? ws::FrameReader(server) : ws::FrameReader::messages(server, max);
}

void check(bool server, std::string_view d, size_t split, uint64_t max) {
  ws::FrameReader whole = reader(server, max);
  Sink a;
  a.max = max;
  const size_t used = whole.feed(d, a);
  if (used > d.size() || a.data.size() > d.size()) std::abort();
  if (!whole.failure() && used != d.size()) std::abort();
  if (const auto& f = whole.failure()) {
    if (f->code != ws::kCloseProtocolError && f->code != ws::kCloseUnsupportedData &&
        f->code != ws::kCloseInvalidPayload && f->code != ws::kCloseMessageTooBig) {
      std::abort();
    }
  }
  ws::FrameReader pieces = reader(server, max);
  Sink b;
  b.max = max;
  const size_t first = pieces.feed(d.substr(0, split), b);
  if (!pieces.failure() && first == split) pieces.feed(d.substr(split), b);
  if (a.data != b.data || a.controls != b.controls || a.messages != b.messages ||
      whole.failure().has_value() != pieces.failure().has_value()) {
    std::abort();
  }
  if (whole.failure() && whole.failure()->code != pieces.failure()->code) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view d(reinterpret_cast<const char*>(data), size);
  const size_t split = size == 0 ? 0 : data[0] % (size + 1);
  check(true, d, split, 0);
  check(false, d, split, 0);
  check(true, d, split, 64);
  check(false, d, split, 64);
  return 0;
}
