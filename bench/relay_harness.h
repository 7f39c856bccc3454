// SPDX-License-Identifier: Apache-2.0
// The relay benchmark's harness, shared by flow_relay and peers: an in-process hub on a
// LoopThread (Unix socket, TCP, TLS), blocking client sockets that speak FlowProtocol, round trips
// (one message in flight) and streams (1:N, a publisher at most a window ahead of its slowest
// subscriber, so that figures are delivered traffic). Everything fails by throwing Fail.
#pragma once

#include <skrobot/hub/flow/hub_stats.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/loop.h>

#include "temp_dir.h"

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

namespace skr::bench {

namespace flow = skr::flow;
namespace msg = skr::flow::msg;
using flow::Code;
using skr::monotonicNs;
using skr::Nanos;

inline constexpr size_t kKiB = 1024;
inline constexpr size_t kMiB = 1024 * 1024;
inline constexpr size_t kBatchBytes = 256 * kKiB;  // one send() from a publisher
inline constexpr size_t kRecvBytes = 1 * kMiB;     // a subscriber's receive buffer
inline constexpr size_t kWindowBytes = 4 * kMiB;   // how far a publisher may run ahead
inline constexpr size_t kDataOverhead = flow::kFrameHeaderBytes + 2;  // header + channel id
inline constexpr int kIoTimeoutMs = 10000;  // a socket silent this long is an error
inline constexpr const char* kTcpUser = "bench";
inline constexpr const char* kTcpPassword = "bench-relay-password";

struct Fail : std::runtime_error {
  using std::runtime_error::runtime_error;
};
[[noreturn]] inline void fail(const std::string& why) {
  throw Fail(why);
}

// --- sockets -------------------------------------------------------------------------------

enum class Transport { unix_socket, tcp, tls };

const char* transportName(Transport t);

class Socket {
 public:
  Socket() = default;
  explicit Socket(int fd) : fd_(fd) {}
  ~Socket() {
    if (fd_ >= 0) ::close(fd_);
  }
  Socket(Socket&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  Socket& operator=(Socket&& o) noexcept {
    if (this != &o) {
      if (fd_ >= 0) ::close(fd_);
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;
  [[nodiscard]] int fd() const noexcept { return fd_; }

 private:
  int fd_ = -1;
};

std::string errnoText(const char* what);
// Blocking I/O with timeouts (kIoTimeoutMs), TCP_NODELAY on TCP.
void prepare(int fd, Transport t);
Socket connectUnix(const std::string& path);
sockaddr_in loopback(uint16_t port);
Socket connectTcp(uint16_t port);
// Two connected ends with no hub between them: the raw floor (TLS: see rawTlsPair).
std::pair<Socket, Socket> rawPair(Transport t);
void sendAll(int fd, std::string_view bytes);

// --- frames --------------------------------------------------------------------------------

struct FrameView {
  uint8_t code = 0;
  std::string_view body;
};

// Reads frames from a blocking socket into one buffer and hands them out in place: a view stays
// valid until the next fill(). With TLS, fill() decrypts into the same buffer.
class FrameReader {
 public:
  explicit FrameReader(int fd, size_t capacity = kRecvBytes) : fd_(fd), buf_(capacity) {}
  void setTls(flow::TlsSession* tls) { tls_ = tls; }

  // The next complete buffered frame, without I/O.
  bool tryNext(FrameView& f) {
    const size_t have = end_ - begin_;
    if (have < flow::kFrameHeaderBytes) {
      want_ = flow::kFrameHeaderBytes;
      return false;
    }
    uint32_t len = 0;
    std::memcpy(&len, buf_.data() + begin_, 4);
    if (len == 0 || len > flow::kDefaultMaxFrameBytes) {
      fail("bad frame length " + std::to_string(len) + " from the peer");
    }
    if (have < 4 + size_t{len}) {
      want_ = 4 + size_t{len};
      return false;
    }
    f.code = static_cast<uint8_t>(buf_[begin_ + 4]);
    f.body = std::string_view(buf_.data() + begin_ + flow::kFrameHeaderBytes, len - 1);
    begin_ += 4 + size_t{len};
    return true;
  }

  // One recv() into the free end of the buffer (blocking, with the socket's timeout).
  void fill() {
    if (begin_ == end_) {
      begin_ = end_ = 0;
    } else if (buf_.size() - end_ < 64 * kKiB || buf_.size() - begin_ < want_) {
      std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (buf_.size() < want_) buf_.resize(want_ + 64 * kKiB);
    if (tls_ != nullptr) {
      fillTls();
      return;
    }
    for (;;) {
      const ssize_t n = ::recv(fd_, buf_.data() + end_, buf_.size() - end_, 0);
      if (n > 0) {
        end_ += static_cast<size_t>(n);
        return;
      }
      if (n == 0) fail("connection closed by the peer");
      if (errno == EINTR) continue;
      fail(errno == EAGAIN ? std::string("no data for 10 s (frames missing or peer stuck)")
                           : errnoText("recv"));
    }
  }

  FrameView next() {
    FrameView f;
    while (!tryNext(f)) fill();
    return f;
  }

 private:
  // Decrypts what is buffered in the session; receives more ciphertext when that is nothing.
  void fillTls() {
    for (;;) {
      size_t got = 0;
      while (end_ < buf_.size()) {
        auto n = tls_->read(buf_.data() + end_, buf_.size() - end_);
        if (!n) fail("TLS: " + n.error().message);
        if (*n == 0) break;
        end_ += *n;
        got += *n;
      }
      if (got > 0) return;
      cipher_.resize(kRecvBytes);
      const ssize_t n = ::recv(fd_, cipher_.data(), cipher_.size(), 0);
      if (n == 0) fail("connection closed by the peer");
      if (n < 0) {
        if (errno == EINTR) continue;
        fail(errno == EAGAIN ? std::string("no data for 10 s (frames missing or peer stuck)")
                             : errnoText("recv"));
      }
      if (auto r = tls_->receive(std::string_view(cipher_.data(), static_cast<size_t>(n))); !r) {
        fail("TLS: " + r.error().message);
      }
    }
  }

  int fd_;
  flow::TlsSession* tls_ = nullptr;
  std::vector<char> cipher_;
  std::vector<char> buf_;
  size_t begin_ = 0, end_ = 0, want_ = flow::kFrameHeaderBytes;
};

// One end of a connection: to the hub (a logged-in flow) or to the other raw end; encrypted when
// it has a TLS session (established already).
struct Peer {
  explicit Peer(Socket s) : sock(std::move(s)), in(sock.fd()) {}
  Peer(Socket s, flow::TlsSession session) : sock(std::move(s)), in(sock.fd()) {
    tls.emplace(std::move(session));
    in.setTls(&*tls);
  }
  void send(std::string_view bytes) const {
    if (!tls) {
      sendAll(sock.fd(), bytes);
      return;
    }
    if (auto w = tls->write(bytes); !w) fail("TLS: " + w.error().message);
    cipher_out.clear();
    tls->takeOutput(cipher_out);
    sendAll(sock.fd(), cipher_out);
  }
  template <class M>
  void sendMsg(const M& m) const {
    std::string out;
    if (!flow::encode(out, m)) fail("cannot encode a setup frame");
    send(out);
  }
  Socket sock;
  mutable std::optional<flow::TlsSession> tls;
  mutable std::string cipher_out;
  FrameReader in;
};
using PeerPtr = std::unique_ptr<Peer>;

// --- TLS -----------------------------------------------------------------------------------

// The test CA and the hub's certificate (localhost), made once per run.
class Certificates {
 public:
  Certificates();  // runs MAKE_TEST_CERTS into a temp dir; fails without openssl
  [[nodiscard]] std::string file(const char* name) const { return (dir_.path() / name).string(); }
  [[nodiscard]] const flow::TlsContext& server() const { return *server_; }
  [[nodiscard]] const flow::TlsContext& client() const { return *client_; }

 private:
  skr::test::TempDir dir_{"skrobot-bench-certs"};
  std::optional<flow::TlsContext> server_, client_;
};

// --- threads -------------------------------------------------------------------------------

// A client thread whose exception becomes an error message for the main thread.
class Worker {
 public:
  template <class F>
  explicit Worker(F f)
      : thread_([this, f = std::move(f)]() mutable {
          try {
            f();
          } catch (const std::exception& e) {
            error_ = e.what();
            failed_.store(true);
          }
        }) {}
  ~Worker() {
    if (thread_.joinable()) thread_.join();
  }
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;
  Worker(Worker&&) = delete;
  Worker& operator=(Worker&&) = delete;

  [[nodiscard]] bool failed() const { return failed_.load(); }
  // Joins, then rethrows the thread's error, if any.
  void join(const char* who) {
    if (thread_.joinable()) thread_.join();
    if (failed_.load()) fail(std::string(who) + ": " + error_);
  }

 private:
  std::string error_;
  std::atomic<bool> failed_{false};
  std::thread thread_;
};

extern const Certificates* g_certs;  // set by main when TLS runs

flow::TlsSession openSession(const flow::TlsContext& ctx);
// The client's handshake with a hub on a blocking socket.
flow::TlsSession clientHandshake(int fd);
// The raw TLS floor: a loopback TCP pair, the handshake done in memory between the two sessions.
std::pair<PeerPtr, PeerPtr> rawTlsPair();

// Data arrives as EV_DATA through the hub and as PUBLISH over a raw socket: same layout.
bool isData(uint8_t code);
// A PUBLISH frame; the first 8 payload bytes carry a sequence number (see stampSeq).
void appendPublish(std::string& out, uint16_t chan, size_t payload);
void stampSeq(char* frame, uint64_t seq);
// A data frame's channel and sequence number; fails on anything unexpected.
uint64_t dataSeq(const FrameView& f, uint16_t chan, size_t payload);

template <class M>
M decodeOrFail(const FrameView& f) {
  auto r = flow::decode<M>(f.body);
  if (!r) fail("undecodable frame: " + r.error().message);
  return std::move(r).value();
}

[[noreturn]] void failOnEvError(const FrameView& f, const char* during);

// --- the hub -------------------------------------------------------------------------------

struct HubOptions {
  size_t queue_bytes = 8 * kMiB;  // ServerOptions::subscriber_queue_bytes
  long busy_poll_us = 50;         // the hub loop's busy_poll_us (50: the config default)
  bool tcp = false;               // a TCP listener on a free loopback port, with a real account
  bool tls = false;               // that listener speaks TLS (g_certs)
};

// A FlowServer on its own loop thread, as the tests run it.
class Hub {
 public:
  explicit Hub(const HubOptions& o);
  ~Hub();
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;
  Hub(Hub&&) = delete;
  Hub& operator=(Hub&&) = delete;

  [[nodiscard]] PeerPtr dial(Transport t) const;
  [[nodiscard]] flow::ServerStats stats();
  [[nodiscard]] uint16_t tcpPort() const noexcept { return tcp_port_; }
  // Runs `fn` on the hub's loop thread with its loop and server, and waits for it.
  void onLoop(const std::function<void(skr::Loop&, flow::FlowServer&)>& fn) {
    thread_->loop().invoke([&] { fn(thread_->loop(), *server_); });
  }

 private:
  static void createAccount(const std::filesystem::path& path);

  skr::test::TempDir dir_{"skrobot-bench"};
  std::string unix_path_;
  uint16_t tcp_port_ = 0;
  std::unique_ptr<skr::LoopThread> thread_;
  std::unique_ptr<flow::FlowServer> server_;
  std::unique_ptr<flow::HubStats> stats_;  // hub.stats and hub.inspect, as the hub has them
};

// --- hub clients: login, channels, subscriptions ----------------------------------------------

uint32_t nextTag();
std::string nextChannelName(const char* what);
void expectReplyOk(Peer& p, const char* what);
// A logged-in flow (guest on the Unix socket, the bench account on TCP).
PeerPtr loginFlow(const Hub& hub, Transport t);
uint16_t addChannel(Peer& owner, const std::string& name);
// SUBSCRIBE, then a barrier: returns once the subscription is in place.
void subscribe(Peer& p, uint16_t chan);
void waitStartPublish(Peer& owner, uint16_t chan);

// --- round trip ----------------------------------------------------------------------------

struct Latency {
  double p50_us = 0, p99_us = 0;
};

Latency percentiles(std::vector<Nanos>& samples);

// A ping-pong pair: A publishes on chan_a, B answers each message on chan_b.
struct PingPair {
  PeerPtr a, b;
  uint16_t chan_a = 1, chan_b = 2;
};

// B: answers each message on chan_a with the same payload on chan_b.
void echo(Peer& b, uint16_t chan_a, uint16_t chan_b, size_t payload, int count);
// A: one message in flight; appends the round trips after the first `warmup` to `samples`.
void pingPong(PingPair& p, size_t payload, int rounds, int warmup, std::vector<Nanos>& samples);
// Round trips per figure at this payload (fewer for --quick).
int roundsFor(size_t payload, bool quick);
PingPair rawPingPair(Transport t);
PingPair hubPingPair(const Hub& hub, Transport t);

// --- streaming: 1:1 and fan-out --------------------------------------------------------------

struct Stream {
  std::vector<Peer*> writers;  // the publisher's connection (hub), or one raw end per subscriber
  std::vector<Peer*> readers;  // one per subscriber
  uint16_t chan = 0;
  size_t payload = 0;
  size_t batch_bytes = kBatchBytes;    // frames per send() from the publisher
  size_t window_bytes = kWindowBytes;  // how far the publisher may run ahead of its slowest reader
};

struct Throughput {
  uint64_t delivered = 0;  // data frames, all subscribers
  uint64_t dropped = 0;
  double total_rate = 0;    // delivered frames/s, all subscribers
  double per_sub_rate = 0;  // total_rate / subscribers
  double mb_s = 0;          // payload MiB/s, all subscribers
};

// Publishes for `seconds`, then waits until every subscriber has every frame (or its drop).
Throughput runStream(const Stream& s, double seconds);
Throughput rawStream(Transport t, size_t subscribers, size_t payload, double seconds);
Throughput hubStream(const Hub& hub, Transport t, size_t subscribers, size_t payload,
                     double seconds, size_t batch_bytes = kBatchBytes,
                     size_t window_bytes = kWindowBytes);

// --- text ----------------------------------------------------------------------------------

std::string sizeText(size_t bytes);
std::string fmt(const char* f, double a, double b = 0);
std::string rateText(double per_s);

}  // namespace skr::bench
