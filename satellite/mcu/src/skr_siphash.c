/* SPDX-License-Identifier: Apache-2.0 */
#include "skr_siphash.h"

#define SKR_ROTL(x, b) (uint64_t)(((x) << (b)) | ((x) >> (64 - (b))))

static uint64_t load64(const uint8_t* p) {
  uint64_t v = 0;
  int i;
  for (i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

static void store64(uint8_t* p, uint64_t v) {
  int i;
  for (i = 0; i < 8; ++i) {
    p[i] = (uint8_t)v;
    v >>= 8;
  }
}

static void rounds(skr_siphash_ctx* c, int n) {
  while (n-- > 0) {
    c->v0 += c->v1;
    c->v1 = SKR_ROTL(c->v1, 13);
    c->v1 ^= c->v0;
    c->v0 = SKR_ROTL(c->v0, 32);
    c->v2 += c->v3;
    c->v3 = SKR_ROTL(c->v3, 16);
    c->v3 ^= c->v2;
    c->v0 += c->v3;
    c->v3 = SKR_ROTL(c->v3, 21);
    c->v3 ^= c->v0;
    c->v2 += c->v1;
    c->v1 = SKR_ROTL(c->v1, 17);
    c->v1 ^= c->v2;
    c->v2 = SKR_ROTL(c->v2, 32);
  }
}

static void compress(skr_siphash_ctx* c, uint64_t m) {
  c->v3 ^= m;
  rounds(c, 2);
  c->v0 ^= m;
}

void skr_siphash_init(skr_siphash_ctx* ctx, const uint8_t key[16], uint8_t out_len) {
  const uint64_t k0 = load64(key);
  const uint64_t k1 = load64(key + 8);
  ctx->v0 = UINT64_C(0x736f6d6570736575) ^ k0;
  ctx->v1 = UINT64_C(0x646f72616e646f6d) ^ k1;
  ctx->v2 = UINT64_C(0x6c7967656e657261) ^ k0;
  ctx->v3 = UINT64_C(0x7465646279746573) ^ k1;
  ctx->out_len = out_len == 16 ? 16 : 8;
  if (ctx->out_len == 16) ctx->v1 ^= 0xee;
  ctx->tail_len = 0;
  ctx->total = 0;
}

void skr_siphash_update(skr_siphash_ctx* ctx, const uint8_t* data, size_t n) {
  size_t i;
  for (i = 0; i < n; ++i) {
    ctx->tail[ctx->tail_len++] = data[i];
    ctx->total = (uint8_t)(ctx->total + 1);
    if (ctx->tail_len == 8) {
      compress(ctx, load64(ctx->tail));
      ctx->tail_len = 0;
    }
  }
}

void skr_siphash_final(skr_siphash_ctx* ctx, uint8_t* out) {
  uint64_t b = (uint64_t)ctx->total << 56;
  int i;
  for (i = ctx->tail_len - 1; i >= 0; --i) b |= (uint64_t)ctx->tail[i] << (8 * i);
  compress(ctx, b);
  ctx->v2 ^= ctx->out_len == 16 ? 0xee : 0xff;
  rounds(ctx, 4);
  store64(out, ctx->v0 ^ ctx->v1 ^ ctx->v2 ^ ctx->v3);
  if (ctx->out_len != 16) return;
  ctx->v1 ^= 0xdd;
  rounds(ctx, 4);
  store64(out + 8, ctx->v0 ^ ctx->v1 ^ ctx->v2 ^ ctx->v3);
}

void skr_siphash(const uint8_t key[16], const uint8_t* data, size_t n, uint8_t* out,
                 uint8_t out_len) {
  skr_siphash_ctx c;
  skr_siphash_init(&c, key, out_len);
  skr_siphash_update(&c, data, n);
  skr_siphash_final(&c, out);
}

int skr_siphash_equal(const uint8_t* a, const uint8_t* b, size_t n) {
  uint8_t d = 0;
  size_t i;
  for (i = 0; i < n; ++i) d |= (uint8_t)(a[i] ^ b[i]);
  return d == 0;
}
