/* SPDX-License-Identifier: Apache-2.0 */
#include "skr_line.h"

uint16_t skr_line_crc16(uint16_t crc, const uint8_t* data, size_t n) {
  /* A byte at a time without a table (the polynomial's terms as shifts; the same values as the
   * bit-by-bit loop it replaces), with no flash or RAM for a table. A board computes it over a
   * whole frame while nothing reads its serial port: at 1,000,000 baud, bit by bit, the Uno's
   * 64-byte receive buffer overflowed meanwhile (docs/microcontrollers.md, "Fast lines"). */
  for (size_t i = 0; i < n; ++i) {
    uint8_t x = (uint8_t)((crc >> 8) ^ data[i]);
    x ^= (uint8_t)(x >> 4);
    crc = (uint16_t)((crc << 8) ^ ((uint16_t)x << 12) ^ ((uint16_t)x << 5) ^ x);
  }
  return crc;
}

/* The bytes encoded: the version, the frame, the CRC, read one at a time without a copy. */
typedef struct {
  const uint8_t* frame;
  size_t n;
  uint8_t head;
  uint8_t tail[2];
} source;

static uint8_t at(const source* s, size_t i) {
  if (i == 0) return s->head;
  if (i <= s->n) return s->frame[i - 1];
  return s->tail[i - 1 - s->n];
}

size_t skr_line_encode(const uint8_t* frame, size_t n, uint8_t* out, size_t cap) {
  if (cap < n + SKR_LINE_OVERHEAD(n)) return 0;
  source s;
  s.frame = frame;
  s.n = n;
  s.head = (uint8_t)SKR_LINE_VERSION;
  uint16_t crc = skr_line_crc16(0xFFFFu, &s.head, 1);
  crc = skr_line_crc16(crc, frame, n);
  s.tail[0] = (uint8_t)(crc & 0xFFu);
  s.tail[1] = (uint8_t)(crc >> 8);

  const size_t total = n + 3;
  size_t w = 0;
  size_t code_at = w++; /* where the current block's code byte goes */
  uint8_t code = 1;
  for (size_t i = 0; i < total; ++i) {
    const uint8_t byte = at(&s, i);
    if (byte == 0) {
      out[code_at] = code;
      code_at = w++;
      code = 1;
      continue;
    }
    out[w++] = byte;
    if (++code == 0xFF) {
      out[code_at] = code;
      code_at = w++;
      code = 1;
    }
  }
  out[code_at] = code;
  out[w++] = (uint8_t)SKR_LINE_DELIMITER;
  return w;
}

void skr_line_rx_init(skr_line_rx* rx, uint8_t* buf, size_t cap) {
  rx->buf = buf;
  rx->cap = cap;
  rx->len = 0;
  rx->left = 0;
  rx->zero = 0;
  rx->started = 0;
  rx->dropping = 0;
  rx->stats.frames = 0;
  rx->stats.bad_check = 0;
  rx->stats.bad_framing = 0;
  rx->stats.bad_version = 0;
  rx->stats.too_long = 0;
}

static void restart(skr_line_rx* rx) {
  rx->len = 0;
  rx->left = 0;
  rx->zero = 0;
  rx->started = 0;
  rx->dropping = 0;
}

static size_t finish(skr_line_rx* rx) {
  if (rx->dropping) {
    restart(rx);
    return 0;
  }
  if (!rx->started) return 0; /* delimiters in a row: an idle line, nothing lost */
  if (rx->left != 0 || rx->len <= SKR_LINE_RX_EXTRA) {
    ++rx->stats.bad_framing;
    restart(rx);
    return 0;
  }
  const size_t len = rx->len;
  const uint16_t crc = skr_line_crc16(0xFFFFu, rx->buf, len - 2);
  const uint16_t sent = (uint16_t)(rx->buf[len - 2] | ((uint16_t)rx->buf[len - 1] << 8));
  restart(rx);
  if (crc != sent) {
    ++rx->stats.bad_check;
    return 0;
  }
  if (rx->buf[0] != SKR_LINE_VERSION) {
    ++rx->stats.bad_version;
    return 0;
  }
  ++rx->stats.frames;
  return len - SKR_LINE_RX_EXTRA;
}

static void put(skr_line_rx* rx, uint8_t byte) {
  if (rx->len == rx->cap) {
    ++rx->stats.too_long;
    rx->dropping = 1;
    return;
  }
  rx->buf[rx->len++] = byte;
}

size_t skr_line_rx_byte(skr_line_rx* rx, uint8_t byte) {
  if (byte == SKR_LINE_DELIMITER) return finish(rx);
  if (rx->dropping) return 0;
  if (rx->left == 0) {
    /* A code byte: the previous block's implicit zero first, then this block's length. */
    if (rx->started && rx->zero) put(rx, 0);
    rx->started = 1;
    rx->left = (uint8_t)(byte - 1);
    rx->zero = byte != 0xFF;
    return 0;
  }
  put(rx, byte);
  --rx->left;
  return 0;
}
