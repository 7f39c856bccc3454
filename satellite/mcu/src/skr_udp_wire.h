/* SPDX-License-Identifier: Apache-2.0 */
/* A board's UDP session, its datagrams byte by byte (docs/flow-protocol.md, "UDP"): the
 * handshake (HELLO -> COOKIE -> OPEN -> ACCEPT) with the board's 16-byte key, then DATA (one whole
 * FlowProtocol frame each) and CLOSE, MACed with the session key, numbered per direction, with a
 * 64-datagram replay window. Every datagram starts `u8 type, u8 version`; integers little-endian.
 *
 *   HELLO   1, 1, str8 user, u8[8] client_nonce, zeros up to 64 bytes
 *   COOKIE  2, 1, u8[8] client_nonce, u8[16] cookie
 *   OPEN    3, 1, str8 user, u8[8] client_nonce, u8[16] cookie, u8[16] mac   (SipHash-128, key)
 *   ACCEPT  4, 1, u8[8] client_nonce, u32 session, u8[8] server_nonce, u8[16] mac (idem)
 *   DATA    5, 1, u32 session, u32 seq, frame, u8[8] mac          (SipHash-2-4, session key)
 *   CLOSE   6, 1, u32 session, u32 seq, u8[8] mac                 (idem)
 *   session key = SipHash-128(key, "skr-udp-session" | client_nonce | server_nonce)
 *
 * This file is the wire only (no sockets, no clock, no randomness: the port brings those):
 * C99, no heap, no stdio, for the board and the POSIX port (satellite/mcu/posix/skr_udp.h). */
#ifndef SKR_UDP_WIRE_H
#define SKR_UDP_WIRE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SKR_UDP_VERSION 1u
#define SKR_UDP_HELLO 1u
#define SKR_UDP_COOKIE 2u
#define SKR_UDP_OPEN 3u
#define SKR_UDP_ACCEPT 4u
#define SKR_UDP_DATA 5u
#define SKR_UDP_CLOSE 6u

#define SKR_UDP_HELLO_BYTES 64u /* a HELLO is padded to this at least; a COOKIE is 26 */
#define SKR_UDP_COOKIE_BYTES 26u
#define SKR_UDP_ACCEPT_BYTES 38u
#define SKR_UDP_DATA_OVERHEAD 18u /* type, version, session, seq, mac */
#define SKR_UDP_MAX_USER 64u

typedef struct {
  uint32_t bad_mac;   /* dropped: the MAC did not match */
  uint32_t replayed;  /* dropped: a sequence number seen already, or older than the window */
  uint32_t lost;      /* sequence numbers skipped and not arrived (yet) */
  uint32_t reordered; /* arrived after a later one, inside the window: delivered */
  uint32_t other;     /* dropped: another session, another type, cut short */
} skr_udp_stats;

typedef struct {
  uint8_t key[16];         /* the board's key (skrobot user key NAME) */
  uint8_t session_key[16]; /* set by ACCEPT */
  uint8_t client_nonce[8]; /* this handshake's: fresh for every HELLO */
  uint32_t session;        /* 0: no session */
  uint32_t seq_out;        /* the last number sent */
  uint32_t seq_in;         /* the highest number received */
  uint64_t window;         /* bit i: seq_in - i was received */
  skr_udp_stats stats;
} skr_udp_session;

/* Forgets any session; keeps the key. */
void skr_udp_init(skr_udp_session* s, const uint8_t key[16]);

/* Each make_* writes a datagram to out (cap bytes) and returns its size, 0 when it does not fit
 * (or the user name is longer than SKR_UDP_MAX_USER). */
size_t skr_udp_make_hello(skr_udp_session* s, const char* user, const uint8_t nonce[8],
                          uint8_t* out, size_t cap);
size_t skr_udp_make_open(const skr_udp_session* s, const char* user, const uint8_t cookie[16],
                         uint8_t* out, size_t cap);
/* DATA carrying one whole frame; numbers it (s->seq_out). */
size_t skr_udp_make_data(skr_udp_session* s, const uint8_t* frame, size_t n, uint8_t* out,
                         size_t cap);
size_t skr_udp_make_close(skr_udp_session* s, uint8_t* out, size_t cap);
/* The same in parts, for a transport that sends a datagram piece by piece (Arduino's UDP): numbers
 * it and writes its head (SKR_UDP_HEAD_BYTES: type, version, session, seq) and the MAC of head
 * and frame (8 bytes); the datagram is head | frame | mac. 0 when no session is open, else 1. */
#define SKR_UDP_HEAD_BYTES 10u
int skr_udp_seal(skr_udp_session* s, uint8_t type, const uint8_t* frame, size_t n,
                 uint8_t head[SKR_UDP_HEAD_BYTES], uint8_t mac[8]);

/* 1 when `in` is the COOKIE answering this handshake's HELLO (the cookie copied out), else 0. */
int skr_udp_take_cookie(const skr_udp_session* s, const uint8_t* in, size_t n, uint8_t cookie[16]);
/* 1 when `in` is the ACCEPT of this handshake and its MAC holds: the session is open. */
int skr_udp_take_accept(skr_udp_session* s, const uint8_t* in, size_t n);

#define SKR_UDP_RX_NONE 0  /* dropped (counted in s->stats), or not for this session */
#define SKR_UDP_RX_DATA 1  /* a frame: in[*off .. *off + *len) */
#define SKR_UDP_RX_CLOSE 2 /* the hub ended the session (s->session is 0 now) */
int skr_udp_take(skr_udp_session* s, const uint8_t* in, size_t n, size_t* off, size_t* len);
/* The same for a datagram read in parts: head (SKR_UDP_HEAD_BYTES), frame (n bytes), mac (8). */
int skr_udp_take_parts(skr_udp_session* s, const uint8_t* head, const uint8_t* frame, size_t n,
                       const uint8_t* mac);

/* The replay window, shared by both ends' rules: 1 when `seq` is new (and now recorded), 0 when
 * it is a duplicate or older than the window (counted as replayed). */
int skr_udp_window(uint32_t* highest, uint64_t* window, skr_udp_stats* stats, uint32_t seq);

#ifdef __cplusplus
}
#endif

#endif
