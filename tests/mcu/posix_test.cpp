// SPDX-License-Identifier: Apache-2.0
// The board library's POSIX port (satellite/mcu/posix/skr_posix.h) on a pseudo-terminal: the tty
// is raw (every byte passes unchanged both ways, 0x00 and control characters included) and the io
// reads one byte at a time without blocking.
#include "skr_posix.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>
#include <cerrno>
#include <cstdlib>
#include <string>

namespace {

struct Pty {
  Pty() {
    master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master >= 0 && grantpt(master) == 0 && unlockpt(master) == 0) name = ptsname(master);
  }
  ~Pty() {
    if (master >= 0) close(master);
  }
  int master = -1;
  std::string name;
};

std::string drain(int fd, size_t want) {
  std::string got;
  while (got.size() < want) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 2000) <= 0) break;
    char buf[64];
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n <= 0) break;
    got.append(buf, static_cast<size_t>(n));
  }
  return got;
}

TEST(Posix, TtyIsRawBothWays) {
  Pty pty;
  ASSERT_FALSE(pty.name.empty());
  const int fd = skr_posix_open_tty(pty.name.c_str(), 115200);
  ASSERT_GE(fd, 0) << errno;
  skr_io io{};
  skr_posix_ctx ctx{};
  skr_posix_io(&io, &ctx, fd);
  EXPECT_EQ(io.read(io.ctx), -1) << "nothing waits: no blocking";

  // Bytes a cooked tty would change or swallow: NUL, ^C, ^D, CR, LF, DEL, 0xFF.
  const std::string line("\x00\x03\x04\r\n\x7f\xff\x11\x13z", 10);
  ASSERT_EQ(write(pty.master, line.data(), line.size()), static_cast<ssize_t>(line.size()));
  std::string got;
  for (int tries = 0; got.size() < line.size() && tries < 2000; ++tries) {
    const int c = io.read(io.ctx);
    if (c < 0) {
      usleep(1000);
      continue;
    }
    got.push_back(static_cast<char>(c));
  }
  EXPECT_EQ(got, line);

  io.write(io.ctx, reinterpret_cast<const uint8_t*>(line.data()), line.size());
  EXPECT_EQ(drain(pty.master, line.size()), line);
  close(fd);
}

TEST(Posix, RefusesAnUnknownBaudRate) {
  Pty pty;
  errno = 0;
  EXPECT_EQ(skr_posix_open_tty(pty.name.c_str(), 12345), -1);
  EXPECT_EQ(errno, EINVAL);
  EXPECT_EQ(skr_posix_open_tty("/nonexistent/tty", 115200), -1);
}

TEST(Posix, ClockIsMonotonicMilliseconds) {
  const uint32_t a = skr_posix_millis(nullptr);
  usleep(20000);
  const uint32_t b = skr_posix_millis(nullptr);
  EXPECT_GE(b - a, 19u);
  EXPECT_LT(b - a, 2000u);
}

}  // namespace
