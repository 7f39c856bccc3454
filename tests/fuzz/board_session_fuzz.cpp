// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes from the line into the board's session (satellite/mcu/src/
// skr_flow.h) through skr_poll, with its clock moving. The first byte picks the form: raw line
// bytes, or frames ([u8 n][n bytes][u8 ms/16]) that the harness wraps in the line framing so that
// the session's decoder sees them whole, or (bit 1) the same frames given whole to a session
// without a line (io.read NULL, skr_input_frame: the UDP transport's way). Whatever arrives, every
// frame the board sends is whole (its length field matches) and within SKR_TX_MAX, and a callback
// never sees more than arrived.
#include "skr_flow.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

struct Line {
  std::vector<uint8_t> in;
  size_t at = 0, stop = 0;  // skr_poll reads up to `stop`
  uint32_t clock = 0;
  std::vector<uint8_t> out_buf = std::vector<uint8_t>(SKR_TX_MAX + SKR_LINE_RX_EXTRA);
  skr_line_rx out{};
};

int readByte(void* ctx) {
  auto* l = static_cast<Line*>(ctx);
  return l->at < l->stop ? l->in[l->at++] : -1;
}
// A session without a line gets whole frames.
void writeFrame(void*, const uint8_t* f, size_t n) {
  uint32_t len;
  if (n < 5 || n > SKR_TX_MAX) std::abort();
  std::memcpy(&len, f, 4);
  if (len != n - 4) std::abort();
}
void writeBytes(void* ctx, const uint8_t* data, size_t n) {
  auto* l = static_cast<Line*>(ctx);
  for (size_t i = 0; i < n; ++i) {
    const size_t m = skr_line_rx_byte(&l->out, data[i]);
    if (m == 0) continue;
    const uint8_t* f = skr_line_rx_frame(&l->out);
    uint32_t len;
    std::memcpy(&len, f, 4);
    if (m < 5 || m > SKR_TX_MAX || len != m - 4) std::abort();
  }
  if (l->out.stats.bad_check + l->out.stats.bad_framing + l->out.stats.too_long != 0) std::abort();
}
uint32_t millis(void* ctx) {
  return static_cast<Line*>(ctx)->clock;
}

void onData(void*, const uint8_t* p, size_t n) {
  if (n > SKR_RX_MAX) std::abort();
  volatile uint8_t sink = 0;
  for (size_t i = 0; i < n; ++i) sink = sink ^ p[i];  // every byte readable
}
void onPulse(void*, uint32_t, uint32_t) {}
void onService(void*, const char* cmd, size_t cmd_n, const uint8_t* v, size_t vn, skr_out* answer) {
  int64_t i;
  double d;
  const char* s;
  size_t sn;
  if (skr_value_string(v, vn, &s, &sn))
    skr_put_string(answer, s, sn);
  else if (skr_value_int64(v, vn, &i))
    skr_put_int64(answer, i);
  else if (skr_value_float64(v, vn, &d))
    skr_put_float64(answer, d);
  else
    skr_put_string(answer, cmd, cmd_n);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static Line l;
  static skr_flow f;
  l = Line{};
  skr_line_rx_init(&l.out, l.out_buf.data(), l.out_buf.size());
  const bool whole = data[0] & 2;
  skr_io io{&l, whole ? nullptr : readByte, whole ? writeFrame : writeBytes, millis};
  skr_init(&f, &io, "robot", "secret", "fuzz");
  const int ch = skr_channel(&f, "analog", "application/x-u16le");
  skr_service_add(&f, "board", onService, nullptr);
  skr_subscribe(&f, "guest.setpoint", onData, nullptr);
  skr_follow(&f, "robot.pulse", onPulse, nullptr);

  skr_poll(&f);
  const bool frames = data[0] & 1;
  size_t i = 1;
  while (i < size) {
    if (whole) {
      const size_t n = data[i++];
      const size_t take = n < size - i ? n : size - i;
      std::vector<uint8_t> frame(data + i,
                                 data + i + take);  // exactly its bytes: ASan sees overreads
      skr_input_frame(&f, frame.data(), frame.size());
      i += take;
      l.clock += i < size ? data[i++] * 16u : 0;
    } else if (frames) {
      const size_t n = data[i++];
      const size_t take = n < size - i ? n : size - i;
      std::vector<uint8_t> enc(take + SKR_LINE_OVERHEAD(take));
      const size_t w = skr_line_encode(data + i, take, enc.data(), enc.size());
      l.in.insert(l.in.end(), enc.begin(), enc.begin() + w);
      i += take;
      l.clock += i < size ? data[i++] * 16u : 0;
    } else {
      const size_t take = size - i < 24 ? size - i : 24;
      l.in.insert(l.in.end(), data + i, data + i + take);
      i += take;
      l.clock += 150;
    }
    l.stop = l.in.size();
    skr_poll(&f);
    const uint8_t two[2] = {1, 2};
    (void)skr_publish(&f, ch, two, sizeof two);
  }
  const skr_stats* s = skr_get_stats(&f);
  if (s->logins == 0) std::abort();  // the session starts at the first poll
  return 0;
}
