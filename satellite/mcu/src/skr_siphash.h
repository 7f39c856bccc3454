/* SPDX-License-Identifier: Apache-2.0 */
/* SipHash-2-4 (Aumasson and Bernstein), with a 64-bit or a 128-bit output: the MACs of a board's
 * UDP session (docs/flow-protocol.md, "UDP"). The 64-bit output is libsodium's
 * crypto_shorthash_siphash24, the 128-bit one its crypto_shorthash_siphashx24 (the hub's side).
 *
 * C99, no heap, no stdio; incremental, so that a board MACs a header and a frame without copying
 * them together. On AVR: 64-bit additions, rotations and XOR only (no division). */
#ifndef SKR_SIPHASH_H
#define SKR_SIPHASH_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SKR_SIPHASH_KEY_BYTES 16u

typedef struct {
  uint64_t v0, v1, v2, v3;
  uint8_t tail[8]; /* bytes not yet compressed */
  uint8_t tail_len;
  uint8_t out_len; /* 8 or 16 */
  uint8_t total;   /* the message's length, modulo 256 (all SipHash keeps of it) */
} skr_siphash_ctx;

/* out_len: 8 (SipHash-2-4) or 16 (SipHash-2-4 with a 128-bit output). */
void skr_siphash_init(skr_siphash_ctx* ctx, const uint8_t key[16], uint8_t out_len);
void skr_siphash_update(skr_siphash_ctx* ctx, const uint8_t* data, size_t n);
/* Writes ctx's out_len bytes to out. */
void skr_siphash_final(skr_siphash_ctx* ctx, uint8_t* out);

/* The whole message at once. */
void skr_siphash(const uint8_t key[16], const uint8_t* data, size_t n, uint8_t* out,
                 uint8_t out_len);

/* 1 when the n bytes at a and b are equal; the time taken does not depend on where they differ. */
int skr_siphash_equal(const uint8_t* a, const uint8_t* b, size_t n);

#ifdef __cplusplus
}
#endif

#endif
