// SPDX-License-Identifier: Apache-2.0
// Commands on a non-blocking stdin, one a line: how the test programs paths_publisher and
// paths_subscriber are driven.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <string>

namespace skr::test {

// Reads what stdin has now and calls on_line for each whole line; `pending` keeps a line's
// beginning until its end comes. False when stdin is closed (the test went away).
template <class OnLine>
bool readStdinLines(std::string& pending, OnLine&& on_line) {
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(0, buf, sizeof buf);
    if (n == 0) return false;
    if (n < 0) break;
    pending.append(buf, static_cast<std::size_t>(n));
  }
  for (std::size_t eol; (eol = pending.find('\n')) != std::string::npos;) {
    const std::string line = pending.substr(0, eol);
    pending.erase(0, eol + 1);
    on_line(line);
  }
  return true;
}

}  // namespace skr::test
