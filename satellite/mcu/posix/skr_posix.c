/* SPDX-License-Identifier: Apache-2.0 */
#define _POSIX_C_SOURCE 200809L
#define _DEFAULT_SOURCE /* cfmakeraw, B230400 and up */
#include "skr_posix.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

static speed_t speed_of(unsigned baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
#ifdef B230400
    case 230400:
      return B230400;
#endif
#ifdef B460800
    case 460800:
      return B460800;
#endif
#ifdef B500000
    case 500000:
      return B500000;
#endif
#ifdef B1000000
    case 1000000:
      return B1000000;
#endif
    default:
      return 0;
  }
}

int skr_posix_open_tty(const char* device, unsigned baud) {
  const speed_t speed = speed_of(baud);
  if (speed == 0) {
    errno = EINVAL;
    return -1;
  }
  const int fd = open(device, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return -1;
  struct termios t;
  if (tcgetattr(fd, &t) != 0) goto fail;
  cfmakeraw(&t);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cflag &= ~(tcflag_t)(CSTOPB | CRTSCTS);
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  if (cfsetispeed(&t, speed) != 0 || cfsetospeed(&t, speed) != 0) goto fail;
  if (tcsetattr(fd, TCSANOW, &t) != 0) goto fail;
  return fd;
fail : {
  const int e = errno;
  close(fd);
  errno = e;
  return -1;
}
}

static int fd_read(void* ctx) {
  uint8_t b;
  const ssize_t n = read(((skr_posix_ctx*)ctx)->fd, &b, 1);
  return n == 1 ? b : -1;
}

static void fd_write(void* ctx, const uint8_t* data, size_t n) {
  const int fd = ((skr_posix_ctx*)ctx)->fd;
  while (n > 0) {
    const ssize_t w = write(fd, data, n);
    if (w > 0) {
      data += w;
      n -= (size_t)w;
    } else if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
      struct pollfd p;
      p.fd = fd;
      p.events = POLLOUT;
      p.revents = 0;
      if (poll(&p, 1, 100) <= 0) return; /* stopped (XOFF, a full line): dropped, as on a board */
    } else {
      return; /* the line is gone: the session notices the silence and logs in again */
    }
  }
}

uint32_t skr_posix_millis(void* ctx) {
  (void)ctx;
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (uint32_t)((uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u);
}

void skr_posix_io(skr_io* io, skr_posix_ctx* ctx, int fd) {
  ctx->fd = fd;
  io->ctx = ctx;
  io->read = fd_read;
  io->write = fd_write;
  io->millis = skr_posix_millis;
}
