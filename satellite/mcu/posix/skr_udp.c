/* SPDX-License-Identifier: Apache-2.0 */
#define _POSIX_C_SOURCE 200809L
#include "skr_udp.h"

#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static long long now_ms(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (long long)t.tv_sec * 1000 + t.tv_nsec / 1000000;
}

int skr_udp_random(uint8_t* out, size_t n) {
  const int fd = open("/dev/urandom", O_RDONLY | O_CLOEXEC);
  size_t got = 0;
  if (fd < 0) return -1;
  while (got < n) {
    const ssize_t r = read(fd, out + got, n - got);
    if (r <= 0) break;
    got += (size_t)r;
  }
  close(fd);
  return got == n ? 0 : -1;
}

/* One datagram within timeout_ms: its size, 0 when none, -1 on a socket error. */
static ssize_t receive(skr_udp* u, int timeout_ms) {
  struct pollfd p;
  ssize_t n;
  p.fd = u->fd;
  p.events = POLLIN;
  p.revents = 0;
  if (poll(&p, 1, timeout_ms < 0 ? 0 : timeout_ms) <= 0) return 0;
  n = recv(u->fd, u->rx, sizeof u->rx, 0);
  if (n < 0) return 0; /* ECONNREFUSED from an ICMP answer, EAGAIN: nothing for now */
  return n;
}

/* Sends `out` every 200 ms until `take` accepts an answer or the deadline passes. */
static int exchange(skr_udp* u, size_t out_n, long long deadline, int step, uint8_t cookie[16]) {
  long long next = 0;
  for (;;) {
    const long long now = now_ms();
    ssize_t n;
    if (now >= deadline) return -1;
    if (now >= next) {
      (void)send(u->fd, u->tx, out_n, 0);
      next = now + 200;
    }
    n = receive(u, (int)((next < deadline ? next : deadline) - now));
    if (n <= 0) continue;
    if (step == SKR_UDP_COOKIE && skr_udp_take_cookie(&u->s, u->rx, (size_t)n, cookie)) return 0;
    if (step == SKR_UDP_ACCEPT && skr_udp_take_accept(&u->s, u->rx, (size_t)n)) return 0;
  }
}

int skr_udp_socket(const char* host, uint16_t port) {
  struct addrinfo hints;
  struct addrinfo* res = 0;
  char service[8];
  int fd;
  memset(&hints, 0, sizeof hints);
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_DGRAM;
  {
    /* snprintf is stdio: the port's digits by hand. */
    char digits[6];
    int i = 0, j = 0;
    unsigned p = port;
    do {
      digits[i++] = (char)('0' + p % 10);
      p /= 10;
    } while (p > 0);
    while (i > 0) service[j++] = digits[--i];
    service[j] = '\0';
  }
  if (getaddrinfo(host, service, &hints, &res) != 0 || res == 0) return -1;
  fd = socket(res->ai_family, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0 || connect(fd, res->ai_addr, res->ai_addrlen) != 0) {
    freeaddrinfo(res);
    if (fd >= 0) close(fd);
    return -1;
  }
  freeaddrinfo(res);
  return fd;
}

int skr_udp_open(skr_udp* u, const char* host, uint16_t port, const char* user,
                 const uint8_t key[16], int timeout_ms) {
  uint8_t nonce[8];
  uint8_t cookie[16];
  size_t n;
  const long long deadline = now_ms() + timeout_ms;
  skr_udp_init(&u->s, key);
  u->fd = skr_udp_socket(host, port);
  if (u->fd < 0) return -1;
  if (skr_udp_random(nonce, sizeof nonce) != 0) goto fail;
  n = skr_udp_make_hello(&u->s, user, nonce, u->tx, sizeof u->tx);
  if (n == 0 || exchange(u, n, deadline, SKR_UDP_COOKIE, cookie) != 0) goto fail;
  n = skr_udp_make_open(&u->s, user, cookie, u->tx, sizeof u->tx);
  if (n == 0 || exchange(u, n, deadline, SKR_UDP_ACCEPT, cookie) != 0) goto fail;
  return 0;
fail:
  close(u->fd);
  u->fd = -1;
  return -1;
}

int skr_udp_send(skr_udp* u, const uint8_t* frame, size_t n) {
  const size_t w = skr_udp_make_data(&u->s, frame, n, u->tx, sizeof u->tx);
  if (u->fd < 0 || w == 0) return -1;
  return send(u->fd, u->tx, w, 0) == (ssize_t)w ? 0 : -1;
}

int skr_udp_poll(skr_udp* u, int timeout_ms, const uint8_t** frame, size_t* n) {
  const long long deadline = now_ms() + timeout_ms;
  if (u->fd < 0 || u->s.session == 0) return -1;
  for (;;) {
    size_t off = 0, len = 0;
    const long long left = deadline - now_ms();
    const ssize_t got = receive(u, left < 0 ? 0 : (int)left);
    if (got > 0) {
      const int r = skr_udp_take(&u->s, u->rx, (size_t)got, &off, &len);
      if (r == SKR_UDP_RX_DATA) {
        *frame = u->rx + off;
        *n = len;
        return 1;
      }
      if (r == SKR_UDP_RX_CLOSE) return -1;
      continue;
    }
    if (now_ms() >= deadline) return 0;
  }
}

void skr_udp_close(skr_udp* u) {
  if (u->fd < 0) return;
  if (u->s.session != 0) {
    const size_t n = skr_udp_make_close(&u->s, u->tx, sizeof u->tx);
    if (n > 0) (void)send(u->fd, u->tx, n, 0);
  }
  close(u->fd);
  u->fd = -1;
  u->s.session = 0;
}
