/* SPDX-License-Identifier: Apache-2.0 */
/* A board's session (skr_flow.h) over UDP datagrams (skr_udp_wire.h): the handshake with the
 * board's key, then one whole frame per DATA datagram, and a new UDP session whenever the session
 * logs in again (the hub restarted, fell silent, or closed the session).
 *
 * The port brings the socket, the clock and randomness (skr_udp_port): the Arduino class
 * SkRobotFlowUdp over Arduino's UDP, posix/skr_udp_flow.h on Linux. C99, no heap, no stdio.
 *
 *   static skr_flow f;
 *   static skr_udp_link l;
 *   skr_udp_link_init(&l, &f, &port, "robot", key, "esp32");   (then skr_channel(&f, ...) ...)
 *   loop: each datagram received: skr_udp_link_input(&l, d, n); then skr_udp_link_poll(&l);
 *
 * How it goes: no session: HELLO (a fresh nonce) -> COOKIE -> OPEN -> ACCEPT, each step sent
 * again after a wait that doubles (SKR_UDP_RETRY_MS up to SKR_BACKOFF_MAX_MS), and a fresh HELLO
 * after SKR_UDP_OPEN_TRIES unanswered OPENs. Once open: skr_poll() runs the flow, whose frames go
 * out as DATA. A LOGIN the flow sends on a session that already carried one means the flow lost
 * the hub: the session is closed (CLOSE) and a new one opened first. A CLOSE from the hub ends
 * the session the same way. The hub takes the LOGIN of the key's account only; its password is
 * ignored (the key proved who the board is). */
#ifndef SKR_UDP_LINK_H
#define SKR_UDP_LINK_H

#include "skr_flow.h"
#include "skr_udp_wire.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifndef SKR_UDP_RETRY_MS /* the first wait for a COOKIE or an ACCEPT */
#define SKR_UDP_RETRY_MS 250u
#endif
#ifndef SKR_UDP_OPEN_TRIES /* OPENs sent for one cookie before a fresh HELLO */
#define SKR_UDP_OPEN_TRIES 4u
#endif
/* The largest handshake datagram (an OPEN with a SKR_UDP_MAX_USER-byte name), built on the stack
 * while it is sent. */
#define SKR_UDP_HANDSHAKE_MAX (43u + SKR_UDP_MAX_USER)

/* The socket, the clock and randomness, from the port. send: one datagram, head | body | tail
 * (body and tail may be empty); the port sends it whole or not at all. */
typedef struct {
  void* ctx;
  void (*send)(void* ctx, const uint8_t* head, size_t head_n, const uint8_t* body, size_t body_n,
               const uint8_t* tail, size_t tail_n);
  void (*random)(void* ctx, uint8_t* out, size_t n); /* nonces: fresh at every handshake */
  uint32_t (*millis)(void* ctx);
} skr_udp_port;

typedef struct {
  uint32_t handshakes;    /* HELLOs sent with a fresh nonce */
  uint32_t sessions;      /* ACCEPTs taken: UDP sessions opened */
  uint32_t closed_by_hub; /* CLOSEs received */
  uint32_t frames_unsent; /* frames the flow sent while no session was open */
} skr_udp_link_stats;

typedef struct {
  skr_udp_session s;
  skr_udp_port port;
  skr_flow* f;
  const char* user;
  uint8_t cookie[16];
  uint8_t step;  /* where the handshake is (internal) */
  uint8_t used;  /* a LOGIN went over this session */
  uint8_t tries; /* OPENs sent for this cookie */
  uint16_t wait_ms;
  uint32_t due_ms;
  skr_udp_link_stats stats;
} skr_udp_link;

/* Sets up the flow f (skr_init over this link: whole frames, no password) and the link; the
 * handshake starts at the first skr_udp_link_poll(). Strings are the caller's (literals). */
void skr_udp_link_init(skr_udp_link* l, skr_flow* f, const skr_udp_port* port, const char* user,
                       const uint8_t key[16], const char* client_name);
/* A whole datagram from the hub (from the hub's address only: the port filters). */
void skr_udp_link_input(skr_udp_link* l, const uint8_t* d, size_t n);
/* A DATA or CLOSE datagram read in parts (head SKR_UDP_HEAD_BYTES, frame, mac 8 bytes); the frame
 * may lie in skr_frame_buffer(f). */
void skr_udp_link_input_parts(skr_udp_link* l, const uint8_t* head, const uint8_t* frame, size_t n,
                              const uint8_t* mac);
/* Runs the handshake's timers, or the flow (skr_poll) once a session is open. */
void skr_udp_link_poll(skr_udp_link* l);
/* 1 while a UDP session is open. */
int skr_udp_link_open(const skr_udp_link* l);
/* Sends CLOSE when a session is open, and forgets it. */
void skr_udp_link_close(skr_udp_link* l);

#ifdef __cplusplus
}
#endif

#endif /* SKR_UDP_LINK_H */
