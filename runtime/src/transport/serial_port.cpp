// SPDX-License-Identifier: Apache-2.0
// The serial line (skrobot/runtime/flow/serial.h): a raw tty, the line framing of skr_line.h, one
// session at a time.
#include <skrobot/runtime/flow/serial.h>
#include <skrobot/runtime/loop_handles.h>

#include "message_session.h"
#include "skr_line.h"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

namespace skr::flow::transport {
namespace {

speed_t speedOf(uint32_t baud) {
  switch (baud) {
#define SKR_BAUD(n) \
  case n:           \
    return B##n;
    SKR_BAUD(50)
    SKR_BAUD(75)
    SKR_BAUD(110)
    SKR_BAUD(134)
    SKR_BAUD(150)
    SKR_BAUD(200)
    SKR_BAUD(300)
    SKR_BAUD(600)
    SKR_BAUD(1200)
    SKR_BAUD(1800)
    SKR_BAUD(2400)
    SKR_BAUD(4800)
    SKR_BAUD(9600)
    SKR_BAUD(19200)
    SKR_BAUD(38400)
    SKR_BAUD(57600)
    SKR_BAUD(115200)
    SKR_BAUD(230400)
    SKR_BAUD(460800)
    SKR_BAUD(500000)
    SKR_BAUD(576000)
    SKR_BAUD(921600)
    SKR_BAUD(1000000)
    SKR_BAUD(1152000)
    SKR_BAUD(1500000)
    SKR_BAUD(2000000)
    SKR_BAUD(2500000)
    SKR_BAUD(3000000)
    SKR_BAUD(3500000)
    SKR_BAUD(4000000)
#undef SKR_BAUD
    default:
      return B0;
  }
}

Error systemError(const std::string& device, const char* what, int err) {
  return makeError(err == ENOENT ? Errc::not_found : Errc::io_error,
                   device + ": " + what + ": " + std::strerror(err));
}

// Frames a paused session may have waiting (a board sends one request at a time; more is a
// board that does not wait for its answers).
constexpr size_t kPendingBytes = 64u << 10;

class Port;

// One session on the line (message_session.h); its carrier is the port.
class Session final : public MessageSession {
 public:
  Session(Loop& loop, Port* port, PeerIdentity peer, uint32_t max_frame)
      : MessageSession(loop, TransportKind::serial, std::move(peer), max_frame, kPendingBytes,
                       "the serial session ended"),
        port_(port) {}
  ~Session() override { leave(); }

  // From the port.
  void frame(std::string_view bytes, SerialStats& stats) {
    if (!received(bytes)) ++stats.overrun;
  }
  // A client's session owns its port (openSerialSession).
  void own(std::unique_ptr<SerialPort> port) noexcept { owned_ = std::move(port); }

 private:
  bool sendFrame(std::string_view frame) override;
  void leaveCarrier() noexcept override;

  Port* port_;                         // while attached()
  std::unique_ptr<SerialPort> owned_;  // last: destroyed after leave()
};

class Port final : public SerialPort {
 public:
  // A client's port (accepted empty): one session, opened by openSession(); no LOGIN restarts.
  // pace_bytes_per_s: what the line is given at most (0: all it takes), in bursts of at most
  // kPaceBurstBytes.
  Port(Loop& loop, SerialOptions options, int fd, Accepted accepted, Lost lost,
       uint32_t pace_bytes_per_s)
      : loop_(loop),
        options_(std::move(options)),
        fd_(fd),
        accepted_(std::move(accepted)),
        lost_(std::move(lost)),
        rx_buf_(options_.max_frame + SKR_LINE_RX_EXTRA),
        pace_(pace_bytes_per_s),
        credit_(kPaceBurstBytes),
        credit_at_(monotonicNs()) {
    skr_line_rx_init(&rx_, rx_buf_.data(), rx_buf_.size());
    if (pace_ > 0) pace_timer_ = Timer(loop_, [this] { flush(true); });
  }
  ~Port() override {
    if (session_ != nullptr)
      session_->carrierEnded({TransportEnd::Why::error, "serial port closed"});
    pace_timer_.stop();
    watch_.stop();
    watch_ = {};
    ::close(fd_);
  }

  Result<void> watch() {
    auto w = FdWatch::open(loop_, fd_, [this](unsigned events) { onEvents(events); });
    if (!w) return w.error();
    watch_ = std::move(w).value();
    watch_.watch(FdWatch::readable);
    return {};
  }

  [[nodiscard]] const SerialStats& stats() const noexcept override { return stats_; }
  [[nodiscard]] const SerialOptions& options() const noexcept override { return options_; }
  [[nodiscard]] bool inSession() const noexcept override { return session_ != nullptr; }

  // A session's frame, encoded onto the line if there is room: false when there is none now.
  bool send(std::string_view frame) {
    const size_t need = frame.size() + SKR_LINE_OVERHEAD(frame.size());
    if (need > options_.queue_bytes + SKR_LINE_OVERHEAD(options_.queue_bytes)) {
      ++stats_.dropped_out;  // could never fit: dropped (SESSION_LIMITS keeps them away)
      return true;
    }
    if (out_.size() - out_off_ + need > options_.queue_bytes && out_off_ < out_.size()) {
      return false;
    }
    const size_t at = out_.size();
    out_.resize(at + need);
    const size_t n = skr_line_encode(reinterpret_cast<const uint8_t*>(frame.data()), frame.size(),
                                     reinterpret_cast<uint8_t*>(out_.data() + at), need);
    out_.resize(at + n);
    ++stats_.frames_out;
    flush(false);  // the session is inside a write: no callback into it
    return true;
  }
  void leave(Session* s) noexcept {
    if (session_ == s) session_ = nullptr;
  }
  std::unique_ptr<Session> openSession() {
    PeerIdentity peer;
    peer.kind = TransportKind::serial;
    peer.device = options_.device;
    peer.account = options_.account;
    auto s = std::make_unique<Session>(loop_, this, std::move(peer), options_.max_frame);
    session_ = s.get();
    ++stats_.sessions;
    return s;
  }

 private:
  void onEvents(unsigned events) {
    if ((events & FdWatch::error) != 0) return fail("the device cannot be polled");
    if ((events & FdWatch::writable) != 0) flush(true);
    if ((events & (FdWatch::readable | FdWatch::hangup)) != 0) read();
  }

  void read() {
    uint8_t buf[4096];
    for (;;) {
      const ssize_t n = ::read(fd_, buf, sizeof buf);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      if (n <= 0) return fail(n == 0 ? "the device went away" : std::strerror(errno));
      stats_.bytes_in += static_cast<uint64_t>(n);
      for (ssize_t i = 0; i < n; ++i) {
        const size_t len = skr_line_rx_byte(&rx_, buf[i]);
        if (len != 0)
          frame(std::string_view(reinterpret_cast<const char*>(skr_line_rx_frame(&rx_)), len));
      }
      stats_.bad_check = rx_.stats.bad_check;
      stats_.bad_framing = rx_.stats.bad_framing;
      stats_.bad_version = rx_.stats.bad_version;
      stats_.too_long = rx_.stats.too_long;
    }
  }

  void frame(std::string_view f) {
    ++stats_.frames_in;
    if (!accepted_) {  // a client: its one session, whatever comes
      if (session_ != nullptr) session_->frame(f, stats_);
      return;
    }
    // A LOGIN while a session is open: the board restarted; its old session ends.
    const bool login = f.size() > 4 && static_cast<uint8_t>(f[4]) == 0x01;
    if (session_ != nullptr && login) {
      Session* old = session_;
      session_ = nullptr;
      old->carrierEnded({TransportEnd::Why::peer_closed, "the board logged in again"});
    }
    if (session_ == nullptr)
      accepted_(openSession());  // may close it at once (too many connections)
    if (session_ != nullptr) session_->frame(f, stats_);
  }

  // The bytes the pace lets go now (SIZE_MAX: unpaced).
  size_t allowance() {
    if (pace_ == 0) return SIZE_MAX;
    const Nanos now = monotonicNs();
    credit_ = std::min(static_cast<double>(kPaceBurstBytes),
                       credit_ + static_cast<double>(now - credit_at_) * pace_ / 1e9);
    credit_at_ = now;
    return static_cast<size_t>(credit_);
  }

  // Writes what the line takes now, within the pace; `notify`: tells a session whose write waits
  // that there is room again (only from the loop: the line became writable, or the pace let more
  // go).
  void flush(bool notify) {
    size_t allowed = allowance();
    bool full = false;
    while (out_off_ < out_.size() && allowed > 0) {
      const size_t want = std::min(out_.size() - out_off_, allowed);
      const ssize_t n = ::write(fd_, out_.data() + out_off_, want);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        full = true;
        break;
      }
      if (n < 0) return fail(std::strerror(errno));
      out_off_ += static_cast<size_t>(n);
      stats_.bytes_out += static_cast<uint64_t>(n);
      if (pace_ > 0) {
        allowed -= static_cast<size_t>(n);
        credit_ -= static_cast<double>(n);
      }
    }
    if (out_off_ == out_.size()) {
      out_.clear();
      out_off_ = 0;
      watch_.watch(FdWatch::readable);
    } else if (full) {
      watch_.watch(FdWatch::readable | FdWatch::writable);
    } else {  // the pace holds the rest back: on when the next burst is due
      watch_.watch(FdWatch::readable);
      if (!pace_timer_.active()) {
        const double need =
            static_cast<double>(std::min<size_t>(kPaceBurstBytes, out_.size() - out_off_)) -
            credit_;
        pace_timer_.startIn(static_cast<Nanos>(std::max(need, 1.0) * 1e9 / pace_));
      }
    }
    if (notify && session_ != nullptr && out_.size() - out_off_ < options_.queue_bytes)
      session_->carrierRoom();
  }

  void fail(const std::string& why) {
    watch_.stop();
    if (session_ != nullptr) {
      Session* s = session_;
      session_ = nullptr;
      s->carrierEnded({TransportEnd::Why::error, options_.device + ": " + why});
    }
    if (lost_) lost_(options_.device + ": " + why);  // may destroy this port: last
  }

  Loop& loop_;
  SerialOptions options_;
  int fd_;
  Accepted accepted_;
  Lost lost_;
  FdWatch watch_;
  std::vector<uint8_t> rx_buf_;
  skr_line_rx rx_{};
  std::string out_;  // encoded bytes not written yet, from out_off_
  size_t out_off_ = 0;
  Session* session_ = nullptr;
  SerialStats stats_;
  uint32_t pace_;     // bytes a second, 0: unpaced
  double credit_;     // bytes the pace lets go now (a token bucket of kPaceBurstBytes)
  Nanos credit_at_;   // when credit_ was brought up to date
  Timer pace_timer_;  // the next burst, while the pace holds bytes back
};

bool Session::sendFrame(std::string_view frame) {
  return port_->send(frame);
}

void Session::leaveCarrier() noexcept {
  port_->leave(this);
}

}  // namespace

Result<int> openSerialDevice(const std::string& device, uint32_t baud) {
  const speed_t speed = speedOf(baud);
  if (speed == B0) {
    return makeError(Errc::invalid_argument, device + ": no serial rate " + std::to_string(baud));
  }
  const int fd = ::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return systemError(device, "open", errno);
  termios t{};
  if (::tcgetattr(fd, &t) != 0) {
    const int err = errno;
    ::close(fd);
    return systemError(device, "not a terminal", err);
  }
  ::cfmakeraw(&t);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cflag &= ~static_cast<tcflag_t>(CRTSCTS | CSTOPB | PARENB);
  t.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  // MIN 1: a read with nothing there is EAGAIN (non-blocking), and 0 means the device hung up
  // (with MIN 0 and TIME 0 an empty read would look like the end).
  t.c_cc[VMIN] = 1;
  t.c_cc[VTIME] = 0;
  ::cfsetispeed(&t, speed);
  ::cfsetospeed(&t, speed);
  if (::tcsetattr(fd, TCSANOW, &t) != 0) {
    const int err = errno;
    ::close(fd);
    return systemError(device, "setting raw mode", err);
  }
  ::tcflush(fd, TCIOFLUSH);
  return fd;
}

Result<std::unique_ptr<SerialPort>> SerialPort::open(Loop& loop, SerialOptions options,
                                                     Accepted accepted, Lost lost) {
  if (options.max_frame < 64) {
    return makeError(Errc::invalid_argument, options.device + ": max_frame below 64 bytes");
  }
  auto fd = openSerialDevice(options.device, options.baud);
  if (!fd) return fd.error();
  const uint32_t pace = pacedBytesPerSecond(options);
  auto port = std::make_unique<Port>(loop, std::move(options), *fd, std::move(accepted),
                                     std::move(lost), pace);
  if (auto r = port->watch(); !r) return r.error();
  return std::unique_ptr<SerialPort>(std::move(port));
}

Result<std::unique_ptr<Transport>> openSerialSession(Loop& loop, const std::string& device,
                                                     uint32_t baud) {
  auto fd = openSerialDevice(device, baud);
  if (!fd) return fd.error();
  SerialOptions options;
  options.device = device;
  options.baud = baud;
  options.max_frame = 1u << 20;
  options.queue_bytes = 64u << 10;
  auto port = std::make_unique<Port>(loop, std::move(options), *fd, nullptr, nullptr, 0);
  if (auto r = port->watch(); !r) return r.error();
  std::unique_ptr<Session> session = port->openSession();
  session->own(std::move(port));
  return std::unique_ptr<Transport>(std::move(session));
}

}  // namespace skr::flow::transport
