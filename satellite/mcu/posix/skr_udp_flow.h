/* SPDX-License-Identifier: Apache-2.0 */
/* A board's whole session over UDP on POSIX (a Linux board, the tests): skr_flow.h over
 * skr_udp_link.h on a UDP socket, with /dev/urandom's nonces and a monotonic clock. C99, no heap.
 *
 *   static skr_flow f;
 *   static skr_udp_flow u;
 *   skr_udp_flow_open(&u, &f, "192.168.1.10", 9001, "robot", key, "linux-board");
 *   skr_channel(&f, ...); skr_subscribe(&f, ...);
 *   for (;;) { skr_udp_flow_poll(&u, 20); skr_publish(&f, ...); }
 */
#ifndef SKR_UDP_FLOW_H
#define SKR_UDP_FLOW_H

#include "skr_udp.h"
#include "skr_udp_link.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
  int fd;
  skr_udp_link link;
  uint8_t rx[SKR_UDP_MAX_DATAGRAM];
} skr_udp_flow;

/* Opens a socket to the hub at host:port and sets up f over it as `user` with its 16-byte key
 * (skr_udp_link_init); the handshake starts at the first poll. 0, or -1 when the address does not
 * resolve or no socket opens. */
int skr_udp_flow_open(skr_udp_flow* u, skr_flow* f, const char* host, uint16_t port,
                      const char* user, const uint8_t key[16], const char* client_name);
/* Waits up to timeout_ms for datagrams, takes every one waiting, and runs the link and the flow
 * (skr_udp_link_poll). */
void skr_udp_flow_poll(skr_udp_flow* u, int timeout_ms);
/* Sends CLOSE when a session is open, and closes the socket. */
void skr_udp_flow_close(skr_udp_flow* u);

#ifdef __cplusplus
}
#endif

#endif /* SKR_UDP_FLOW_H */
