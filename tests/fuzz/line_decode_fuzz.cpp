// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as a serial line into the board library's line receiver
// (satellite/mcu/src/skr_line.h), with a small buffer: it never writes past the buffer and every
// frame it gives back fits it; the first bytes, encoded, come back whole through a fresh receiver.
#include "skr_line.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  constexpr size_t kMax = 64;
  std::vector<uint8_t> buf(kMax + SKR_LINE_RX_EXTRA);
  skr_line_rx rx;
  skr_line_rx_init(&rx, buf.data(), buf.size());
  uint32_t frames = 0;
  for (size_t i = 0; i < size; ++i) {
    const size_t n = skr_line_rx_byte(&rx, data[i]);
    if (n > kMax) std::abort();
    if (n > 0) ++frames;
  }
  if (frames != rx.stats.frames) std::abort();

  const size_t n = size < kMax ? size : kMax;
  std::vector<uint8_t> line(n + SKR_LINE_OVERHEAD(n));
  const size_t w = skr_line_encode(data, n, line.data(), line.size());
  if (w == 0 || std::memchr(line.data(), 0, w - 1) != nullptr || line[w - 1] != 0) std::abort();
  skr_line_rx_init(&rx, buf.data(), buf.size());
  size_t got = 0;
  for (size_t i = 0; i < w; ++i) got = skr_line_rx_byte(&rx, line[i]);
  if (n > 0 && (got != n || std::memcmp(skr_line_rx_frame(&rx), data, n) != 0)) std::abort();
  return 0;
}
