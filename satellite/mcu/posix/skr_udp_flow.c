/* SPDX-License-Identifier: Apache-2.0 */
#define _POSIX_C_SOURCE 200809L
#include "skr_udp_flow.h"

#include "skr_posix.h"

#include <poll.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

static void send_parts(void* ctx, const uint8_t* head, size_t head_n, const uint8_t* body,
                       size_t body_n, const uint8_t* tail, size_t tail_n) {
  const skr_udp_flow* u = (const skr_udp_flow*)ctx;
  struct iovec v[3];
  struct msghdr m = {0};
  v[0].iov_base = (void*)head;
  v[0].iov_len = head_n;
  v[1].iov_base = (void*)body;
  v[1].iov_len = body_n;
  v[2].iov_base = (void*)tail;
  v[2].iov_len = tail_n;
  m.msg_iov = v;
  m.msg_iovlen = 3;
  (void)sendmsg(u->fd, &m, MSG_DONTWAIT); /* a full buffer: lost, as on the air */
}

static void random_nonce(void* ctx, uint8_t* out, size_t n) {
  (void)ctx;
  (void)skr_udp_random(out, n);
}

int skr_udp_flow_open(skr_udp_flow* u, skr_flow* f, const char* host, uint16_t port,
                      const char* user, const uint8_t key[16], const char* client_name) {
  skr_udp_port p;
  u->fd = skr_udp_socket(host, port);
  p.ctx = u;
  p.send = send_parts;
  p.random = random_nonce;
  p.millis = skr_posix_millis;
  skr_udp_link_init(&u->link, f, &p, user, key, client_name);
  return u->fd < 0 ? -1 : 0;
}

void skr_udp_flow_poll(skr_udp_flow* u, int timeout_ms) {
  struct pollfd p;
  p.fd = u->fd;
  p.events = POLLIN;
  p.revents = 0;
  if (u->fd >= 0 && poll(&p, 1, timeout_ms < 0 ? 0 : timeout_ms) > 0) {
    for (;;) {
      /* ECONNREFUSED (an ICMP answer while the hub is down), EAGAIN: nothing more for now. */
      const ssize_t n = recv(u->fd, u->rx, sizeof u->rx, MSG_DONTWAIT);
      if (n < 0) break;
      skr_udp_link_input(&u->link, u->rx, (size_t)n);
    }
  }
  skr_udp_link_poll(&u->link);
}

void skr_udp_flow_close(skr_udp_flow* u) {
  if (u->fd < 0) return;
  skr_udp_link_close(&u->link);
  close(u->fd);
  u->fd = -1;
}
