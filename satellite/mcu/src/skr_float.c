/* SPDX-License-Identifier: Apache-2.0 */
/* The float helpers, apart so that a board that never calls them links no float code. The wire
 * carries float64; a board's double may be 32 bits (AVR), so the bits are widened or narrowed by
 * hand: no float arithmetic. */
#include "skr_flow.h"

#include <string.h>

static uint64_t bits_of(double v) {
  if (sizeof(double) == 8) {
    uint64_t u;
    memcpy(&u, &v, 8);
    return u;
  }
  uint32_t s;
  memcpy(&s, &v, 4);
  const uint64_t sign = (uint64_t)(s >> 31) << 63;
  const uint32_t e = (s >> 23) & 0xFFu;
  const uint64_t m = (uint64_t)(s & 0x7FFFFFu) << 29;
  if (e == 0) return sign; /* zero; subnormals flush to zero */
  if (e == 0xFFu) return sign | ((uint64_t)0x7FFu << 52) | m;
  return sign | ((uint64_t)(e - 127u + 1023u) << 52) | m;
}

static double of_bits(uint64_t u) {
  double v;
  if (sizeof(double) == 8) {
    memcpy(&v, &u, 8);
    return v;
  }
  const uint32_t sign = (uint32_t)(u >> 63) << 31;
  const int32_t e = (int32_t)((u >> 52) & 0x7FFu);
  const uint32_t m = (uint32_t)(u >> 29) & 0x7FFFFFu;
  uint32_t s;
  if (e == 0x7FF) {
    s = sign | 0x7F800000u | (m != 0 ? (m | 1u) : 0u); /* a NaN stays a NaN */
  } else if (e - 1023 + 127 >= 0xFF) {
    s = sign | 0x7F800000u; /* too large: infinity */
  } else if (e - 1023 + 127 <= 0) {
    s = sign; /* too small: zero */
  } else {
    s = sign | ((uint32_t)(e - 1023 + 127) << 23) | m;
  }
  memcpy(&v, &s, 4);
  return v;
}

void skr_put_float64(skr_out* o, double v) {
  uint8_t b[9];
  uint64_t u = bits_of(v);
  b[0] = 0x04;
  for (uint8_t i = 1; i < 9; ++i, u >>= 8) b[i] = (uint8_t)u;
  if (!o->ok || o->cap - o->len < sizeof b) {
    o->ok = 0;
    return;
  }
  memcpy(o->p + o->len, b, sizeof b);
  o->len += sizeof b;
}

int skr_value_float64(const uint8_t* value, size_t len, double* v) {
  if (len == 9 && value[0] == 0x04) {
    uint64_t u = 0;
    for (uint8_t i = 8; i > 0; --i) u = (u << 8) | value[i];
    *v = of_bits(u);
    return 1;
  }
  int64_t i;
  if (skr_value_int64(value, len, &i)) {
    *v = (double)i;
    return 1;
  }
  return 0;
}

skr_status skr_var_set_float64(skr_flow* f, const char* key, double v) {
  skr_out o;
  const skr_status st = skr_var_begin_(f, &o, key);
  if (st != SKR_OK) return st;
  skr_put_float64(&o, v);
  return skr_send_(f, &o);
}
