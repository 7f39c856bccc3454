/* SPDX-License-Identifier: Apache-2.0 */
/* FlowProtocol frames on a byte line that may lose, flip or insert bytes (a serial port): each
 * frame travels as COBS(version | frame | CRC-16) followed by one 0x00 delimiter. COBS leaves no
 * 0x00 inside a frame, so a receiver that lost its place starts again at the next delimiter; the
 * version byte lets the framing change; the CRC (CRC-16/CCITT-FALSE: polynomial 0x1021, initial
 * 0xFFFF, over the version and the frame, sent low byte first) drops what noise changed.
 *
 * C99, no heap, no stdio: the same code runs on an 8-bit board and in the hub.
 * The receiver decodes byte by byte into a buffer its caller owns; a frame that would not fit is
 * dropped whole and counted, never written past the buffer. */
#ifndef SKR_LINE_H
#define SKR_LINE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SKR_LINE_VERSION 1u
#define SKR_LINE_DELIMITER 0x00u
/* Bytes the line adds around a frame of n bytes at most: version, CRC, COBS's overhead (one byte
 * per 254 and one more) and the delimiter. */
#define SKR_LINE_OVERHEAD(n) (3u + ((n) + 3u) / 254u + 1u + 1u)
/* What a receiver's buffer holds beyond its largest frame: the version and the CRC. */
#define SKR_LINE_RX_EXTRA 3u

uint16_t skr_line_crc16(uint16_t crc, const uint8_t* data, size_t n);

/* Where a frame of n bytes at most may sit in `out` to be encoded in place (a board keeps one
 * buffer): the encoder writes byte k of its output only after reading the frame's byte
 * k - SKR_LINE_INPLACE_LEAD(n) + 1, so frame = out + SKR_LINE_INPLACE_LEAD(n) is safe. */
#define SKR_LINE_INPLACE_LEAD(n) (2u + ((n) + 3u) / 254u)

/* Encodes `frame` (n bytes) into `out` (cap bytes), delimiter included. Returns the bytes written,
 * 0 when cap is less than n + SKR_LINE_OVERHEAD(n). `frame` may lie inside `out`, at
 * SKR_LINE_INPLACE_LEAD(n) bytes or more from its start (and not past it otherwise). */
size_t skr_line_encode(const uint8_t* frame, size_t n, uint8_t* out, size_t cap);

/* Counters a receiver keeps (what hub.stats shows for a serial line). */
typedef struct {
  uint32_t frames;      /* frames received whole and checked */
  uint32_t bad_check;   /* dropped: the CRC did not match */
  uint32_t bad_framing; /* dropped: a COBS block cut short by a delimiter, or an empty frame */
  uint32_t bad_version; /* dropped: a framing version this receiver does not speak */
  uint32_t too_long;    /* dropped: longer than the buffer */
} skr_line_stats;

typedef struct {
  uint8_t* buf; /* the caller's: version, frame and CRC as decoded */
  size_t cap;
  size_t len;
  uint8_t left;     /* data bytes left in the current COBS block */
  uint8_t zero;     /* 1: the current block ends with an implicit 0x00 */
  uint8_t started;  /* 1: a block began since the last delimiter */
  uint8_t dropping; /* 1: this frame is already lost; wait for the delimiter */
  skr_line_stats stats;
} skr_line_rx;

/* buf holds the largest frame accepted plus SKR_LINE_RX_EXTRA. */
void skr_line_rx_init(skr_line_rx* rx, uint8_t* buf, size_t cap);

/* Takes one byte from the line. Returns the length of a frame that ends with this byte and
 * passed its checks (the frame is at skr_line_rx_frame(rx) until the next call), else 0: a
 * dropped frame is counted in rx->stats, and decoding starts again after the next delimiter. */
size_t skr_line_rx_byte(skr_line_rx* rx, uint8_t byte);

static inline const uint8_t* skr_line_rx_frame(const skr_line_rx* rx) {
  return rx->buf + 1;
}

#ifdef __cplusplus
}
#endif

#endif /* SKR_LINE_H */
