/* SPDX-License-Identifier: Apache-2.0 */
/* The board library's UDP transport on POSIX (a Linux board, the tests): a UDP socket to the hub,
 * the handshake and DATA framing of skr_udp_wire.h. A small transport: open, send a frame, poll
 * for a frame, close. One whole FlowProtocol frame per datagram. C99, no heap. */
#ifndef SKR_UDP_H
#define SKR_UDP_H

#include "skr_udp_wire.h"

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#ifndef SKR_UDP_MAX_DATAGRAM
#define SKR_UDP_MAX_DATAGRAM 1500u /* the largest datagram sent or received */
#endif

typedef struct skr_udp {
  int fd;
  skr_udp_session s;
  uint8_t rx[SKR_UDP_MAX_DATAGRAM];
  uint8_t tx[SKR_UDP_MAX_DATAGRAM];
} skr_udp;

/* Opens a session with the hub at host:port (a numeric address or a name) as `user` with its
 * 16-byte key: HELLO, COOKIE, OPEN, ACCEPT, each step sent again every 200 ms until `timeout_ms`.
 * 0 when the session is open, -1 otherwise (u->fd is -1 then). */
int skr_udp_open(skr_udp* u, const char* host, uint16_t port, const char* user,
                 const uint8_t key[16], int timeout_ms);
/* Sends one whole frame: 0, or -1 when it does not fit a datagram or the socket refuses. */
int skr_udp_send(skr_udp* u, const uint8_t* frame, size_t n);
/* Waits up to timeout_ms for a frame: 1 with *frame (valid until the next call) and *n, 0 when
 * none came, -1 when the session ended (the hub sent CLOSE) or the socket failed. Datagrams
 * that fail their checks are dropped and counted (u->s.stats). */
int skr_udp_poll(skr_udp* u, int timeout_ms, const uint8_t** frame, size_t* n);
/* Sends CLOSE (when a session is open) and closes the socket. */
void skr_udp_close(skr_udp* u);

/* The parts the transports share: a UDP socket connected to host:port (a descriptor, or -1), and
 * n random bytes from /dev/urandom (0, or -1). */
int skr_udp_socket(const char* host, uint16_t port);
int skr_udp_random(uint8_t* out, size_t n);

#ifdef __cplusplus
}
#endif

#endif
