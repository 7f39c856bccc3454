// SPDX-License-Identifier: Apache-2.0
// Test helpers for boards in simavr (tests/boards): a simulated board (simavr_runner), a line
// relay (line_relay), and a serial port opened raw that speaks the line framing
// (satellite/mcu/src/skr_line.h). Header-only; the hub's serial tests use the first two and
// give the hub the pseudo-terminal's name instead of a LinePort.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>
#include "hub_process.h"
#include "skr_line.h"

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace skr::boards::test {

using skr::sat::test::Child;
using Bytes = std::vector<uint8_t>;
namespace fs = std::filesystem;

// The last `PTY <name>` line of a runner's or relay's output, or "".
inline std::string lastPty(const std::string& output) {
  const size_t at = output.rfind("PTY /dev/");
  if (at == std::string::npos) return {};
  const size_t end = output.find('\n', at);
  if (end == std::string::npos) return {};  // not flushed whole yet
  return output.substr(at + 4, end - at - 4);
}

// A program that prints `PTY <name>` when its terminal is ready (the runner, the relay).
class PtyProcess {
 public:
  PtyProcess(std::vector<std::string> argv, const fs::path& log)
      : child_(std::make_unique<Child>(argv, std::vector<std::string>{}, log)) {
    skr::test::eventually([&] { return !lastPty(child_->output()).empty() || !child_->running(); },
                          10000);
    pty_ = lastPty(child_->output());
  }
  // The terminal's name ("" when the program failed to start: see output()).
  [[nodiscard]] const std::string& pty() const { return pty_; }
  // Waits for the program's n-th `PTY` line (a relay's replug: the name may be the same).
  bool waitPty(size_t n, int timeout_ms = 10000) {
    return skr::test::eventually(
        [&] {
          const std::string out = child_->output();
          size_t count = 0;
          for (size_t at = out.find("PTY /dev/"); at != std::string::npos;
               at = out.find("PTY /dev/", at + 1)) {
            if (out.find('\n', at) != std::string::npos) ++count;
          }
          pty_ = lastPty(out);
          return count >= n;
        },
        timeout_ms);
  }
  void signal(int sig) const { child_->signal(sig); }
  // SIGTERM, the exit code; output() then has the program's last line.
  int stop() {
    child_->signal(SIGTERM);
    return child_->wait(10000);
  }
  [[nodiscard]] std::string output() const { return child_->output(); }
  [[nodiscard]] bool running() { return child_->running(); }

 private:
  std::unique_ptr<Child> child_;
  std::string pty_;
};

// An Arduino sketch's ELF in simavr_runner (SIMAVR_RUNNER_BIN). `args`: --realtime, --limit-ms,
// --reset-at-ms. reset() asks for a reset at the next step (SIGUSR1).
class SimBoard : public PtyProcess {
 public:
  SimBoard(const std::string& runner, const std::string& elf, const fs::path& dir,
           std::vector<std::string> args = {"--realtime"})
      : PtyProcess(argv(runner, elf, std::move(args)), dir / logName()) {}
  void reset() const { signal(SIGUSR1); }

 private:
  static std::vector<std::string> argv(const std::string& runner, const std::string& elf,
                                       std::vector<std::string> args) {
    args.insert(args.begin(), {runner, elf});
    return args;
  }
  static std::string logName() {
    static int n = 0;
    return "board-" + std::to_string(++n) + ".log";
  }
};

// line_relay (LINE_RELAY_BIN) in front of a board's terminal: --baud, --seed, --error-rate,
// --unplug-at-ms, --replug-after-ms, --link.
class LineRelay : public PtyProcess {
 public:
  LineRelay(const std::string& relay, const std::string& board_tty, const fs::path& dir,
            std::vector<std::string> args = {})
      : PtyProcess(argv(relay, board_tty, std::move(args)), dir / logName()) {}

 private:
  static std::vector<std::string> argv(const std::string& relay, const std::string& tty,
                                       std::vector<std::string> args) {
    args.insert(args.begin(), {relay, tty});
    return args;
  }
  static std::string logName() {
    static int n = 0;
    return "relay-" + std::to_string(++n) + ".log";
  }
};

// The hub's end of a line, as a test holds it: a terminal opened raw, frames in and out through
// the line framing.
class LinePort {
 public:
  explicit LinePort(const std::string& path, size_t max_frame = 1024)
      : buf_(max_frame + SKR_LINE_RX_EXTRA) {
    skr_line_rx_init(&rx_, buf_.data(), buf_.size());
    fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (fd_ < 0) return;
    termios tio{};
    if (tcgetattr(fd_, &tio) == 0) {
      cfmakeraw(&tio);
      tcsetattr(fd_, TCSANOW, &tio);
    }
  }
  ~LinePort() {
    if (fd_ >= 0) ::close(fd_);
  }
  LinePort(const LinePort&) = delete;
  LinePort& operator=(const LinePort&) = delete;
  LinePort(LinePort&&) = delete;
  LinePort& operator=(LinePort&&) = delete;

  [[nodiscard]] bool ok() const { return fd_ >= 0; }
  // Writes raw bytes (all of them: waits while the terminal is full).
  bool write(const Bytes& bytes) {
    size_t done = 0;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (done < bytes.size() && std::chrono::steady_clock::now() < end) {
      const ssize_t w = ::write(fd_, bytes.data() + done, bytes.size() - done);
      if (w > 0) {
        done += size_t(w);
      } else {
        pollfd p{fd_, POLLOUT, 0};
        ::poll(&p, 1, 10);
      }
    }
    return done == bytes.size();
  }
  bool send(const Bytes& frame) { return write(encode(frame)); }
  // The next frame received whole within timeout_ms, or nothing (hungUp() says whether the
  // terminal went away).
  std::optional<Bytes> next(int timeout_ms = 5000) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    for (;;) {
      while (pos_ < len_) {
        const size_t n = skr_line_rx_byte(&rx_, chunk_[pos_++]);
        if (n > 0) return Bytes(skr_line_rx_frame(&rx_), skr_line_rx_frame(&rx_) + n);
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                            end - std::chrono::steady_clock::now())
                            .count();
      if (left <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, int(left)) <= 0) continue;
      const ssize_t r = ::read(fd_, chunk_, sizeof chunk_);
      if (r > 0) {
        pos_ = 0;
        len_ = size_t(r);
      } else if (r == 0 || (errno != EAGAIN && errno != EINTR)) {
        hung_up_ = true;
        return std::nullopt;
      }
    }
  }
  [[nodiscard]] bool hungUp() const { return hung_up_; }
  [[nodiscard]] const skr_line_stats& stats() const { return rx_.stats; }

  static Bytes encode(const Bytes& frame) {
    Bytes out(frame.size() + SKR_LINE_OVERHEAD(frame.size()));
    out.resize(skr_line_encode(frame.data(), frame.size(), out.data(), out.size()));
    return out;
  }

 private:
  int fd_ = -1;
  Bytes buf_;
  skr_line_rx rx_{};
  uint8_t chunk_[4096];
  size_t pos_ = 0, len_ = 0;
  bool hung_up_ = false;
};

}  // namespace skr::boards::test
