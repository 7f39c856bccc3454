/* SPDX-License-Identifier: Apache-2.0 */
#include "skr_udp_wire.h"

#include "skr_siphash.h"

#include <string.h>

static const char kSessionLabel[] = "skr-udp-session"; /* 15 bytes, no terminator MACed */

static void put32(uint8_t* p, uint32_t v) {
  p[0] = (uint8_t)v;
  p[1] = (uint8_t)(v >> 8);
  p[2] = (uint8_t)(v >> 16);
  p[3] = (uint8_t)(v >> 24);
}

static uint32_t get32(const uint8_t* p) {
  return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

void skr_udp_init(skr_udp_session* s, const uint8_t key[16]) {
  memset(s, 0, sizeof *s);
  memcpy(s->key, key, 16);
}

size_t skr_udp_make_hello(skr_udp_session* s, const char* user, const uint8_t nonce[8],
                          uint8_t* out, size_t cap) {
  const size_t ulen = strlen(user);
  size_t n = 3 + ulen + 8;
  if (ulen > SKR_UDP_MAX_USER) return 0;
  if (n < SKR_UDP_HELLO_BYTES) n = SKR_UDP_HELLO_BYTES;
  if (cap < n) return 0;
  memset(out, 0, n);
  memcpy(s->client_nonce, nonce, 8);
  s->session = 0;
  out[0] = SKR_UDP_HELLO;
  out[1] = SKR_UDP_VERSION;
  out[2] = (uint8_t)ulen;
  memcpy(out + 3, user, ulen);
  memcpy(out + 3 + ulen, nonce, 8);
  return n;
}

int skr_udp_take_cookie(const skr_udp_session* s, const uint8_t* in, size_t n, uint8_t cookie[16]) {
  if (n != SKR_UDP_COOKIE_BYTES || in[0] != SKR_UDP_COOKIE || in[1] != SKR_UDP_VERSION) return 0;
  if (memcmp(in + 2, s->client_nonce, 8) != 0) return 0;
  memcpy(cookie, in + 10, 16);
  return 1;
}

size_t skr_udp_make_open(const skr_udp_session* s, const char* user, const uint8_t cookie[16],
                         uint8_t* out, size_t cap) {
  const size_t ulen = strlen(user);
  const size_t body = 3 + ulen + 8 + 16;
  if (ulen > SKR_UDP_MAX_USER || cap < body + 16) return 0;
  out[0] = SKR_UDP_OPEN;
  out[1] = SKR_UDP_VERSION;
  out[2] = (uint8_t)ulen;
  memcpy(out + 3, user, ulen);
  memcpy(out + 3 + ulen, s->client_nonce, 8);
  memcpy(out + 11 + ulen, cookie, 16);
  skr_siphash(s->key, out, body, out + body, 16);
  return body + 16;
}

int skr_udp_take_accept(skr_udp_session* s, const uint8_t* in, size_t n) {
  uint8_t mac[16];
  skr_siphash_ctx c;
  if (n != SKR_UDP_ACCEPT_BYTES || in[0] != SKR_UDP_ACCEPT || in[1] != SKR_UDP_VERSION) return 0;
  if (memcmp(in + 2, s->client_nonce, 8) != 0) return 0;
  skr_siphash(s->key, in, 22, mac, 16);
  if (!skr_siphash_equal(mac, in + 22, 16)) {
    ++s->stats.bad_mac;
    return 0;
  }
  if (get32(in + 10) == 0) return 0;
  skr_siphash_init(&c, s->key, 16);
  skr_siphash_update(&c, (const uint8_t*)kSessionLabel, sizeof kSessionLabel - 1);
  skr_siphash_update(&c, s->client_nonce, 8);
  skr_siphash_update(&c, in + 14, 8);
  skr_siphash_final(&c, s->session_key);
  s->session = get32(in + 10);
  s->seq_out = 0;
  s->seq_in = 0;
  s->window = 0;
  return 1;
}

int skr_udp_seal(skr_udp_session* s, uint8_t type, const uint8_t* frame, size_t n,
                 uint8_t head[SKR_UDP_HEAD_BYTES], uint8_t mac[8]) {
  skr_siphash_ctx c;
  if (s->session == 0) return 0;
  head[0] = type;
  head[1] = SKR_UDP_VERSION;
  put32(head + 2, s->session);
  put32(head + 6, ++s->seq_out);
  skr_siphash_init(&c, s->session_key, 8);
  skr_siphash_update(&c, head, SKR_UDP_HEAD_BYTES);
  skr_siphash_update(&c, frame, n);
  skr_siphash_final(&c, mac);
  return 1;
}

static size_t make_numbered(skr_udp_session* s, uint8_t type, const uint8_t* frame, size_t n,
                            uint8_t* out, size_t cap) {
  uint8_t head[SKR_UDP_HEAD_BYTES], mac[8];
  if (cap < SKR_UDP_DATA_OVERHEAD || n > cap - SKR_UDP_DATA_OVERHEAD) return 0;
  if (!skr_udp_seal(s, type, frame, n, head, mac)) return 0;
  if (n > 0) memmove(out + SKR_UDP_HEAD_BYTES, frame, n);
  memcpy(out, head, SKR_UDP_HEAD_BYTES);
  memcpy(out + SKR_UDP_HEAD_BYTES + n, mac, 8);
  return n + SKR_UDP_DATA_OVERHEAD;
}

size_t skr_udp_make_data(skr_udp_session* s, const uint8_t* frame, size_t n, uint8_t* out,
                         size_t cap) {
  return make_numbered(s, SKR_UDP_DATA, frame, n, out, cap);
}

size_t skr_udp_make_close(skr_udp_session* s, uint8_t* out, size_t cap) {
  return make_numbered(s, SKR_UDP_CLOSE, 0, 0, out, cap);
}

int skr_udp_window(uint32_t* highest, uint64_t* window, skr_udp_stats* stats, uint32_t seq) {
  uint32_t d;
  if (seq > *highest) {
    d = seq - *highest;
    stats->lost += d - 1;
    *window = d >= 64 ? 0 : *window << d;
    *window |= 1;
    *highest = seq;
    return 1;
  }
  d = *highest - seq;
  if (seq == 0 || d >= 64 || ((*window >> d) & 1u) != 0) {
    ++stats->replayed;
    return 0;
  }
  *window |= (uint64_t)1 << d;
  ++stats->reordered;
  if (stats->lost > 0) --stats->lost; /* the gap it left is filled */
  return 1;
}

int skr_udp_take_parts(skr_udp_session* s, const uint8_t* head, const uint8_t* frame, size_t n,
                       const uint8_t* mac) {
  uint8_t want[8];
  skr_siphash_ctx c;
  if (head[1] != SKR_UDP_VERSION || (head[0] != SKR_UDP_DATA && head[0] != SKR_UDP_CLOSE) ||
      s->session == 0 || get32(head + 2) != s->session) {
    ++s->stats.other;
    return SKR_UDP_RX_NONE;
  }
  skr_siphash_init(&c, s->session_key, 8);
  skr_siphash_update(&c, head, SKR_UDP_HEAD_BYTES);
  skr_siphash_update(&c, frame, n);
  skr_siphash_final(&c, want);
  if (!skr_siphash_equal(want, mac, 8)) {
    ++s->stats.bad_mac;
    return SKR_UDP_RX_NONE;
  }
  if (!skr_udp_window(&s->seq_in, &s->window, &s->stats, get32(head + 6))) return SKR_UDP_RX_NONE;
  if (head[0] == SKR_UDP_CLOSE) {
    s->session = 0;
    return SKR_UDP_RX_CLOSE;
  }
  return SKR_UDP_RX_DATA;
}

int skr_udp_take(skr_udp_session* s, const uint8_t* in, size_t n, size_t* off, size_t* len) {
  if (n < SKR_UDP_DATA_OVERHEAD) {
    ++s->stats.other;
    return SKR_UDP_RX_NONE;
  }
  *off = SKR_UDP_HEAD_BYTES;
  *len = n - SKR_UDP_DATA_OVERHEAD;
  return skr_udp_take_parts(s, in, in + SKR_UDP_HEAD_BYTES, *len, in + n - 8);
}
