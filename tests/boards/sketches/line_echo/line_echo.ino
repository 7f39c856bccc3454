// SPDX-License-Identifier: Apache-2.0
// The line framing alone on a board (satellite/mcu/src/skr_line.h), for tests/boards: sends one
// frame "BOOT" at start, then sends back every frame it receives whole. A frame "?" is answered
// "S" + the receiver's counters (frames, bad_check, bad_framing, bad_version, too_long: u32 LE).
#include <skr_line.h>

static const size_t kMaxFrame = 128;
static uint8_t rx_buf[kMaxFrame + SKR_LINE_RX_EXTRA];
static uint8_t tx_buf[kMaxFrame + SKR_LINE_OVERHEAD(kMaxFrame)];
static skr_line_rx rx;

static void send_frame(const uint8_t* frame, size_t n) {
  const size_t len = skr_line_encode(frame, n, tx_buf, sizeof tx_buf);
  Serial.write(tx_buf, len);
}

static void put_u32(uint8_t* at, uint32_t v) {
  for (uint8_t i = 0; i < 4; ++i) at[i] = (uint8_t)(v >> (8 * i));
}

void setup() {
  Serial.begin(115200);
  skr_line_rx_init(&rx, rx_buf, sizeof rx_buf);
  static const uint8_t boot[] = {'B', 'O', 'O', 'T'};
  send_frame(boot, sizeof boot);
}

void loop() {
  while (Serial.available() > 0) {
    const size_t n = skr_line_rx_byte(&rx, (uint8_t)Serial.read());
    if (n == 0) continue;
    const uint8_t* frame = skr_line_rx_frame(&rx);
    if (n == 1 && frame[0] == '?') {
      uint8_t stats[1 + 5 * 4];
      stats[0] = 'S';
      put_u32(stats + 1, rx.stats.frames);
      put_u32(stats + 5, rx.stats.bad_check);
      put_u32(stats + 9, rx.stats.bad_framing);
      put_u32(stats + 13, rx.stats.bad_version);
      put_u32(stats + 17, rx.stats.too_long);
      send_frame(stats, sizeof stats);
    } else {
      send_frame(frame, n);
    }
  }
}
