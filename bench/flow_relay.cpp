// FlowNetwork relay benchmark: what the hub costs compared with a direct socket between two
// clients. For the Unix socket, TCP and TLS over TCP (loopback), in the same run:
//   round trip   ping-pong A -> hub -> B -> hub -> A, one message in flight: p50/p99
//   1:1          delivered messages/s and MB/s from one publisher to one subscriber
//   fan-out 1:N  delivered messages/s in all and per subscriber, N = 4 and 16
// Every hub figure is printed next to its raw floor: the same framing and batching over a
// socketpair(AF_UNIX) or a loopback TCP connection, with no hub, and as a ratio to it. TLS rows
// run through a second hub whose TCP listener speaks TLS (certificates made at start by
// tests/support/make_test_certs.sh); their raw floor is a TLS session over a loopback TCP
// connection, and a last table puts each TLS figure next to plain TCP's through the hub.
//
// The hub runs in this process on its own LoopThread; clients are plain blocking sockets on
// their own threads. Publishers encode many PUBLISH frames into one buffer and send it with one
// send(); subscribers recv() large chunks and parse frames in place. A publisher never runs more
// than a window (4 MB) ahead of its slowest subscriber, so the figures are delivered traffic,
// not drops; drops (EV_DROPPED) are still counted and reported.
//
// Round trips alternate between raw and hub in blocks, so that load changes touch both alike.
//
//   flow_relay [--quick] [--seconds S] [--unix-only | --tcp-only | --no-tls] [--queue-mb M]
//              [--only round-trip|1:1|fan-out] [--busy-poll-us N]
//
// Exits 1 on a real error (lost connection, frames missing beyond the reported drops, a hub
// that does not answer); a missed target is reported, not an error.
#include <skrobot/core/clock.h>
#include <skrobot/core/log.h>
#include <skrobot/core/loop.h>
#include <skrobot/flow/accounts.h>
#include <skrobot/flow/codec.h>
#include <skrobot/flow/server.h>
#include <skrobot/flow/tls.h>

#include "temp_dir.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

namespace {

namespace flow = skr::flow;
namespace msg = skr::flow::msg;
using flow::Code;
using skr::monotonicNs;
using skr::Nanos;

constexpr size_t kKiB = 1024;
constexpr size_t kMiB = 1024 * 1024;
constexpr size_t kBatchBytes = 256 * kKiB;                     // one send() from a publisher
constexpr size_t kRecvBytes = 1 * kMiB;                        // a subscriber's receive buffer
constexpr size_t kWindowBytes = 4 * kMiB;                      // how far a publisher may run ahead
constexpr size_t kDataOverhead = flow::kFrameHeaderBytes + 2;  // header + channel id
constexpr int kIoTimeoutMs = 10000;  // a socket silent this long is an error
constexpr const char* kTcpUser = "bench";
constexpr const char* kTcpPassword = "bench-relay-password";

struct Fail : std::runtime_error {
  using std::runtime_error::runtime_error;
};
[[noreturn]] void fail(const std::string& why) {
  throw Fail(why);
}

// --- options -------------------------------------------------------------------------------

struct Options {
  bool quick = false;
  double seconds = 1.5;  // per throughput measurement (hub and raw each)
  bool unix_rows = true;
  bool tcp_rows = true;
  bool tls_rows = true;
  size_t queue_bytes = 8 * kMiB;  // ServerOptions::subscriber_queue_bytes
  std::string only;               // empty, "round-trip", "1:1" or "fan-out"
  long busy_poll_us = 50;         // the hub loop's busy_poll_us (50: the config default)
};

void usage() {
  std::printf(
      "usage: flow_relay [--quick] [--seconds S] [--unix-only | --tcp-only | --no-tls]\n"
      "                  [--queue-mb M]\n"
      "                  [--only round-trip|1:1|fan-out] [--busy-poll-us N]\n"
      "  --quick       a short run (a few seconds), used by the test suite as a smoke test\n"
      "  --seconds S   seconds per throughput measurement (default 1.5)\n"
      "  --unix-only   the Unix socket rows only; --tcp-only: TCP and TLS rows; --no-tls: no TLS\n"
      "  --queue-mb M  the hub's subscriber queue in MiB (default 8, the hub's default)\n"
      "  --only TEST   run one kind of test (for profiling)\n"
      "  --busy-poll-us N  the hub loop keeps polling N us after I/O (config loop.busy_poll_us)\n");
}

Options parseOptions(int argc, char** argv) {
  Options o;
  bool seconds_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--seconds" && has_value) {
      o.seconds = std::atof(argv[++i]);
      seconds_given = true;
    } else if (a == "--queue-mb" && has_value) {
      o.queue_bytes = static_cast<size_t>(std::atof(argv[++i]) * kMiB);
    } else if (a == "--busy-poll-us" && has_value) {
      o.busy_poll_us = std::atol(argv[++i]);
    } else if (a == "--only" && has_value) {
      o.only = argv[++i];
    } else if (a == "--unix-only") {
      o.tcp_rows = false;
      o.tls_rows = false;
    } else if (a == "--no-tls") {
      o.tls_rows = false;
    } else if (a == "--tcp-only") {
      o.unix_rows = false;
    } else {
      usage();
      std::exit(a == "--help" || a == "-h" ? 0 : 2);
    }
  }
  if (o.quick && !seconds_given) o.seconds = 0.08;
  const bool only_ok =
      o.only.empty() || o.only == "round-trip" || o.only == "1:1" || o.only == "fan-out";
  if (o.seconds <= 0 || o.queue_bytes < 64 * kKiB || (!o.unix_rows && !o.tcp_rows) || !only_ok) {
    usage();
    std::exit(2);
  }
  return o;
}

// --- sockets -------------------------------------------------------------------------------

enum class Transport { unix_socket, tcp, tls };

const char* transportName(Transport t) {
  return t == Transport::tls ? "tls" : t == Transport::tcp ? "tcp" : "unix";
}

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

std::string errnoText(const char* what) {
  return std::string(what) + ": " + std::strerror(errno);
}

// Blocking I/O with timeouts, so that a hub that stops answering is an error, not a hang.
void prepare(int fd, Transport t) {
  timeval tv{kIoTimeoutMs / 1000, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  if (t != Transport::unix_socket) {
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
}

Socket connectUnix(const std::string& path) {
  Socket s(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
  if (::connect(s.fd(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    fail(errnoText(("connect " + path).c_str()));
  }
  prepare(s.fd(), Transport::unix_socket);
  return s;
}

sockaddr_in loopback(uint16_t port) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return addr;
}

Socket connectTcp(uint16_t port) {
  Socket s(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
  sockaddr_in addr = loopback(port);
  if (::connect(s.fd(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    fail(errnoText("connect 127.0.0.1"));
  }
  prepare(s.fd(), Transport::tcp);
  return s;
}

// Two connected ends with no hub between them: the raw floor (TLS: see rawTlsPair).
std::pair<Socket, Socket> rawPair(Transport t) {
  if (t == Transport::unix_socket) {
    int fds[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) {
      fail(errnoText("socketpair"));
    }
    prepare(fds[0], t);
    prepare(fds[1], t);
    return {Socket(fds[0]), Socket(fds[1])};
  }
  Socket listener(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
  sockaddr_in addr = loopback(0);
  socklen_t len = sizeof addr;
  if (::bind(listener.fd(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      ::listen(listener.fd(), 1) != 0 ||
      ::getsockname(listener.fd(), reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    fail(errnoText("loopback listener"));
  }
  Socket a = connectTcp(ntohs(addr.sin_port));
  Socket b(::accept4(listener.fd(), nullptr, nullptr, SOCK_CLOEXEC));
  if (b.fd() < 0) fail(errnoText("accept"));
  prepare(b.fd(), t);
  return {std::move(a), std::move(b)};
}

void sendAll(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(errno == EAGAIN ? std::string("send timed out: the peer does not read")
                           : errnoText("send"));
    }
    bytes.remove_prefix(static_cast<size_t>(n));
  }
}

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
  Certificates() {
    const std::string cmd =
        std::string("sh ") + MAKE_TEST_CERTS + " " + dir_.path().string() + " >/dev/null 2>&1";
    if (std::system(cmd.c_str()) != 0) fail("make_test_certs.sh failed (is openssl installed?)");
    flow::TlsSettings server;
    server.cert_file = file("hub.pem");
    server.key_file = file("hub.key");
    flow::TlsSettings client;
    client.ca_file = file("ca.pem");
    auto s = flow::TlsContext::create(flow::TlsRole::server, server);
    auto c = flow::TlsContext::create(flow::TlsRole::client, client);
    if (!s || !c) fail("TLS contexts: " + (s ? c.error().message : s.error().message));
    server_.emplace(std::move(s).value());
    client_.emplace(std::move(c).value());
  }
  [[nodiscard]] std::string file(const char* name) const { return (dir_.path() / name).string(); }
  [[nodiscard]] const flow::TlsContext& server() const { return *server_; }
  [[nodiscard]] const flow::TlsContext& client() const { return *client_; }

 private:
  skr::test::TempDir dir_{"skrobot-bench-certs"};
  std::optional<flow::TlsContext> server_, client_;
};

const Certificates* g_certs = nullptr;  // set by main when TLS rows run

flow::TlsSession openSession(const flow::TlsContext& ctx) {
  auto s = flow::TlsSession::open(ctx, "localhost");
  if (!s) fail("TLS session: " + s.error().message);
  return std::move(s).value();
}

// The client's handshake with a hub on a blocking socket.
flow::TlsSession clientHandshake(int fd) {
  flow::TlsSession tls = openSession(g_certs->client());
  std::string out, in(64 * kKiB, '\0');
  for (;;) {
    out.clear();
    tls.takeOutput(out);
    sendAll(fd, out);
    if (tls.established()) return tls;
    const ssize_t n = ::recv(fd, in.data(), in.size(), 0);
    if (n <= 0) fail(errnoText("TLS handshake recv"));
    if (auto r = tls.receive(std::string_view(in.data(), static_cast<size_t>(n))); !r) {
      fail("TLS handshake: " + r.error().message);
    }
  }
}

// The raw TLS floor: a loopback TCP pair, one end client and one server, the handshake done in
// memory between the two sessions.
std::pair<PeerPtr, PeerPtr> rawTlsPair() {
  auto [x, y] = rawPair(Transport::tcp);
  flow::TlsSession a = openSession(g_certs->client());
  flow::TlsSession b = openSession(g_certs->server());
  std::string bytes;
  for (int i = 0; i < 10 && !(a.established() && b.established()); ++i) {
    bytes.clear();
    a.takeOutput(bytes);
    if (auto r = b.receive(bytes); !r) fail("raw TLS handshake: " + r.error().message);
    bytes.clear();
    b.takeOutput(bytes);
    if (auto r = a.receive(bytes); !r) fail("raw TLS handshake: " + r.error().message);
  }
  if (!a.established() || !b.established()) fail("raw TLS handshake did not finish");
  // Session tickets and the like that the server sent last reach the client with the data.
  return {std::make_unique<Peer>(std::move(x), std::move(a)),
          std::make_unique<Peer>(std::move(y), std::move(b))};
}

// Data arrives as EV_DATA through the hub and as PUBLISH over a raw socket: same layout.
bool isData(uint8_t code) {
  return code == uint8_t(Code::ev_data) || code == uint8_t(Code::publish);
}

// A PUBLISH frame; the first 8 payload bytes carry a sequence number (see stampSeq).
void appendPublish(std::string& out, uint16_t chan, size_t payload) {
  flow::appendHeader(out, Code::publish, 2 + payload);
  flow::ByteWriter(out).u16(chan);
  out.append(payload, 'x');
}
void stampSeq(char* frame, uint64_t seq) {
  std::memcpy(frame + kDataOverhead, &seq, 8);
}

// A data frame's channel and sequence number; fails on anything unexpected.
uint64_t dataSeq(const FrameView& f, uint16_t chan, size_t payload) {
  uint16_t got = 0;
  uint64_t seq = 0;
  if (f.body.size() != 2 + payload) {
    fail("data frame of " + std::to_string(f.body.size() - 2) + " bytes, expected " +
         std::to_string(payload));
  }
  std::memcpy(&got, f.body.data(), 2);
  if (got != chan)
    fail("data on channel " + std::to_string(got) + ", expected " + std::to_string(chan));
  std::memcpy(&seq, f.body.data() + 2, 8);
  return seq;
}

template <class M>
M decodeOrFail(const FrameView& f) {
  auto r = flow::decode<M>(f.body);
  if (!r) fail("undecodable frame: " + r.error().message);
  return std::move(r).value();
}

[[noreturn]] void failOnEvError(const FrameView& f, const char* during) {
  const auto e = decodeOrFail<msg::EvError>(f);
  fail(std::string("EV_ERROR during ") + during + ": " +
       std::string(flow::errorCodeName(flow::ErrorCode(e.error))) + ", " + e.message);
}

// --- the hub -------------------------------------------------------------------------------

// A FlowServer on its own loop thread, as the tests run it. TCP gets a real account.
class Hub {
 public:
  // tls: the TCP listener speaks TLS (g_certs), and dial(Transport::tls) reaches it.
  Hub(const Options& o, bool tcp, bool tls = false) {
    flow::ServerOptions so;
    so.app_name = "skrobot-bench-" + std::to_string(::getpid());
    so.unix_path = (dir_.path() / "hub.sock").string();
    so.users_file = dir_.path() / "users.json";
    so.dev_account = std::make_pair(std::string("guest"), std::string("password"));
    so.subscriber_queue_bytes = o.queue_bytes;
    if (tcp) {
      so.tcp_enabled = true;
      so.tcp_port = 0;
      createAccount(so.users_file);
    }
    if (tls) {
      so.tls.emplace();
      so.tls->cert_file = g_certs->file("hub.pem");
      so.tls->key_file = g_certs->file("hub.key");
    }
    unix_path_ = so.unix_path;
    skr::LoopOptions lo;
    lo.name = "hub";
    lo.busy_poll_ns = o.busy_poll_us * 1000;
    thread_ = std::make_unique<skr::LoopThread>(lo);
    thread_->start();
    skr::Result<void> r;
    thread_->loop().invoke([&] {
      server_ = std::make_unique<flow::FlowServer>(thread_->loop(), so);
      r = server_->start();
      tcp_port_ = server_->tcpPort();
    });
    if (!r) {
      thread_->loop().invoke([&] { server_.reset(); });
      fail("hub start: " + r.error().describe());
    }
  }
  ~Hub() {
    thread_->loop().invoke([&] { server_.reset(); });
    thread_.reset();
  }
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;
  Hub(Hub&&) = delete;
  Hub& operator=(Hub&&) = delete;

  [[nodiscard]] PeerPtr dial(Transport t) const {
    if (t == Transport::unix_socket) return std::make_unique<Peer>(connectUnix(unix_path_));
    Socket s = connectTcp(tcp_port_);
    if (t == Transport::tcp) return std::make_unique<Peer>(std::move(s));
    flow::TlsSession session = clientHandshake(s.fd());
    return std::make_unique<Peer>(std::move(s), std::move(session));
  }
  [[nodiscard]] flow::ServerStats stats() {
    flow::ServerStats s;
    thread_->loop().invoke([&] { s = server_->stats(); });
    return s;
  }

 private:
  static void createAccount(const std::filesystem::path& path) {
    auto users = flow::UsersFile::load(path);
    if (!users) fail("users file: " + users.error().describe());
    if (auto r = users->add(kTcpUser, kTcpPassword); !r) fail("add user: " + r.error().describe());
    if (auto r = users->save(); !r) fail("save users: " + r.error().describe());
  }

  skr::test::TempDir dir_{"skrobot-bench"};
  std::string unix_path_;
  uint16_t tcp_port_ = 0;
  std::unique_ptr<skr::LoopThread> thread_;
  std::unique_ptr<flow::FlowServer> server_;
};

// --- hub clients: login, channels, subscriptions ----------------------------------------------

uint32_t nextTag() {
  static uint32_t tag = 100;
  return ++tag;
}

std::string nextChannelName(const char* what) {
  static int n = 0;
  return std::string(what) + "-" + std::to_string(++n);
}

void expectReplyOk(Peer& p, const char* what) {
  const FrameView f = p.in.next();
  if (f.code == uint8_t(Code::reply_error)) {
    fail(std::string(what) + " refused: " + decodeOrFail<msg::ReplyError>(f).message);
  }
  if (f.code != uint8_t(Code::reply_ok)) {
    fail(std::string(what) + ": unexpected " + std::string(flow::codeName(f.code)));
  }
}

PeerPtr loginFlow(const Hub& hub, Transport t) {
  PeerPtr p = hub.dial(t);
  msg::Login m;
  m.user = t != Transport::unix_socket ? kTcpUser : "guest";
  m.password = t != Transport::unix_socket ? kTcpPassword : "password";
  m.client_name = "flow_relay";
  p->sendMsg(m);
  expectReplyOk(*p, "LOGIN");
  p->sendMsg(msg::Empty<Code::go_async>{});
  expectReplyOk(*p, "GO_ASYNC");
  return p;
}

uint16_t addChannel(Peer& owner, const std::string& name) {
  msg::ChanAdd m;
  m.tag = nextTag();
  m.kind = uint8_t(flow::ChannelKind::streaming);
  m.short_name = name;
  m.mime = "application/octet-stream";
  owner.sendMsg(m);
  for (;;) {
    const FrameView f = owner.in.next();
    if (f.code == uint8_t(Code::ev_chan_added)) {
      const auto ev = decodeOrFail<msg::EvChanAdded>(f);
      if (ev.tag == m.tag) return ev.info.id;
    } else if (f.code == uint8_t(Code::ev_error)) {
      failOnEvError(f, "CHAN_ADD");
    }
  }
}

// SUBSCRIBE, then a SUBSCRIBE to channel 0 (never exists) as a barrier: the hub handles a flow's
// commands in order, so its EV_ERROR means the real subscription is in place.
void subscribe(Peer& p, uint16_t chan) {
  const uint32_t tag = nextTag();
  const uint32_t barrier = nextTag();
  p.sendMsg(msg::Subscribe{tag, chan});
  p.sendMsg(msg::Subscribe{barrier, 0});
  for (;;) {
    const FrameView f = p.in.next();
    if (f.code != uint8_t(Code::ev_error)) continue;
    const auto e = decodeOrFail<msg::EvError>(f);
    if (e.tag == barrier) return;
    if (e.tag == tag) failOnEvError(f, "SUBSCRIBE");
  }
}

void waitStartPublish(Peer& owner, uint16_t chan) {
  for (;;) {
    const FrameView f = owner.in.next();
    if (f.code == uint8_t(Code::ev_start_publish) &&
        decodeOrFail<msg::EvStartPublish>(f).chan_id == chan) {
      return;
    }
  }
}

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

// --- round trip ----------------------------------------------------------------------------

struct Latency {
  double p50_us = 0, p99_us = 0;
};

Latency percentiles(std::vector<Nanos>& samples) {
  std::sort(samples.begin(), samples.end());
  const auto at = [&](double q) {
    const size_t i = std::min(samples.size() - 1, static_cast<size_t>(q * samples.size()));
    return static_cast<double>(samples[i]) / 1e3;
  };
  return {at(0.50), at(0.99)};
}

// B: answers each message on chan_a with the same payload on chan_b.
void echo(Peer& b, uint16_t chan_a, uint16_t chan_b, size_t payload, int count) {
  std::string reply;
  appendPublish(reply, chan_b, payload);
  for (int i = 0; i < count;) {
    const FrameView f = b.in.next();
    if (!isData(f.code)) continue;
    const uint64_t seq = dataSeq(f, chan_a, payload);
    if (seq != static_cast<uint64_t>(i)) fail("echo: out of order message " + std::to_string(seq));
    std::memcpy(reply.data() + kDataOverhead, f.body.data() + 2, payload);
    b.send(reply);
    ++i;
  }
}

// A ping-pong pair: A publishes on chan_a, B answers each message on chan_b.
struct PingPair {
  PeerPtr a, b;
  uint16_t chan_a = 1, chan_b = 2;
};

// A: one message in flight; appends the round trips after the first `warmup` to `samples`.
void pingPong(PingPair& p, size_t payload, int rounds, int warmup, std::vector<Nanos>& samples) {
  const int total = warmup + rounds;
  Worker responder([&] { echo(*p.b, p.chan_a, p.chan_b, payload, total); });
  std::string ping;
  appendPublish(ping, p.chan_a, payload);
  try {
    for (int i = 0; i < total; ++i) {
      stampSeq(ping.data(), static_cast<uint64_t>(i));
      const Nanos t0 = monotonicNs();
      p.a->send(ping);
      FrameView f;
      do {
        f = p.a->in.next();
      } while (!isData(f.code));
      if (dataSeq(f, p.chan_b, payload) != static_cast<uint64_t>(i)) fail("ping: wrong answer");
      if (i >= warmup) samples.push_back(monotonicNs() - t0);
    }
  } catch (...) {
    ::shutdown(p.b->sock.fd(), SHUT_RDWR);  // unblocks the responder
    throw;
  }
  responder.join("round trip responder");
}

// --- streaming: 1:1 and fan-out --------------------------------------------------------------

// What one subscriber thread saw; `seen` (received + dropped) paces the publisher.
struct alignas(64) SubStats {
  std::atomic<uint64_t> seen{0};
  uint64_t received = 0;
  uint64_t dropped = 0;  // announced by EV_DROPPED
  uint64_t gaps = 0;     // missing sequence numbers
  Nanos last_ns = 0;     // when the last data frame arrived
};

struct Stream {
  std::vector<Peer*> writers;  // the publisher's connection (hub), or one raw end per subscriber
  std::vector<Peer*> readers;  // one per subscriber
  uint16_t chan = 0;
  size_t payload = 0;
};

// Handles one buffered frame of a subscriber; `expect` is the next sequence number.
void onStreamFrame(const FrameView& f, const Stream& s, SubStats& st, uint64_t& expect) {
  if (isData(f.code)) {
    const uint64_t seq = dataSeq(f, s.chan, s.payload);
    if (seq < expect) fail("sequence went back from " + std::to_string(expect));
    st.gaps += seq - expect;
    expect = seq + 1;
    ++st.received;
  } else if (f.code == uint8_t(Code::ev_dropped)) {
    st.dropped += decodeOrFail<msg::EvDropped>(f).count;
  } else if (f.code == uint8_t(Code::ev_error)) {
    failOnEvError(f, "streaming");
  }
}

// Reads until every frame published (`total`, known once the last batch is on its way) arrived or
// was announced as dropped.
void subscriberLoop(Peer& r, const Stream& s, const std::atomic<uint64_t>& total, SubStats& st) {
  uint64_t expect = 0;
  FrameView f;
  while (st.received + st.dropped < total.load(std::memory_order_acquire)) {
    r.in.fill();
    const uint64_t before = st.received;
    while (r.in.tryNext(f)) onStreamFrame(f, s, st, expect);
    if (st.received != before) st.last_ns = monotonicNs();
    st.seen.store(st.received + st.dropped, std::memory_order_release);
  }
  st.gaps += total.load() - expect;  // lost at the tail
  if (st.gaps != st.dropped) {
    fail(std::to_string(st.gaps) + " frames missing, " + std::to_string(st.dropped) +
         " reported dropped");
  }
}

struct Batch {
  std::string bytes;
  std::vector<size_t> offsets;  // of each frame
};

Batch makeBatch(uint16_t chan, size_t payload) {
  const size_t frame = kDataOverhead + payload;
  const size_t frames = std::max<size_t>(1, kBatchBytes / frame);
  Batch b;
  b.bytes.reserve(frames * frame);
  for (size_t i = 0; i < frames; ++i) {
    b.offsets.push_back(b.bytes.size());
    appendPublish(b.bytes, chan, payload);
  }
  return b;
}

uint64_t slowest(const std::vector<SubStats>& subs) {
  uint64_t m = std::numeric_limits<uint64_t>::max();
  for (const auto& s : subs) m = std::min(m, s.seen.load(std::memory_order_acquire));
  return m;
}

// Publishes batches until `seconds` passed; stores `total` before the last batch is sent.
void publisherLoop(const Stream& s, std::vector<SubStats>& subs, double seconds,
                   std::atomic<uint64_t>& total, const std::vector<std::unique_ptr<Worker>>& ws) {
  Batch batch = makeBatch(s.chan, s.payload);
  const uint64_t k = batch.offsets.size();
  const uint64_t window = std::max<uint64_t>(2 * k, kWindowBytes / (kDataOverhead + s.payload));
  const Nanos deadline = monotonicNs() + static_cast<Nanos>(seconds * 1e9);
  const auto anyFailed = [&] {
    return std::any_of(ws.begin(), ws.end(), [](const auto& w) { return w->failed(); });
  };
  for (uint64_t seq = 0;;) {
    const bool last = monotonicNs() >= deadline;
    while (seq + k > slowest(subs) + window) {
      if (anyFailed()) return;
      std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
    for (uint64_t i = 0; i < k; ++i) stampSeq(batch.bytes.data() + batch.offsets[i], seq + i);
    seq += k;
    if (last) total.store(seq, std::memory_order_release);
    for (Peer* w : s.writers) w->send(batch.bytes);
    if (last) return;
  }
}

struct Throughput {
  uint64_t delivered = 0;  // data frames, all subscribers
  uint64_t dropped = 0;
  double total_rate = 0;    // delivered frames/s, all subscribers
  double per_sub_rate = 0;  // total_rate / subscribers
  double mb_s = 0;          // payload MiB/s, all subscribers
};

Throughput summarize(const std::vector<SubStats>& subs, Nanos start, size_t payload) {
  Throughput t;
  Nanos end = start + 1;  // the last frame's arrival, any subscriber
  for (const auto& s : subs) {
    t.delivered += s.received;
    t.dropped += s.dropped;
    end = std::max(end, s.last_ns);
  }
  const double secs = static_cast<double>(end - start) / 1e9;
  t.total_rate = static_cast<double>(t.delivered) / secs;
  t.per_sub_rate = t.total_rate / static_cast<double>(subs.size());
  t.mb_s = t.total_rate * static_cast<double>(payload) / static_cast<double>(kMiB);
  return t;
}

Throughput runStream(const Stream& s, double seconds) {
  std::vector<SubStats> subs(s.readers.size());
  std::atomic<uint64_t> total{std::numeric_limits<uint64_t>::max()};
  std::vector<std::unique_ptr<Worker>> workers;
  for (size_t i = 0; i < s.readers.size(); ++i) {
    workers.push_back(
        std::make_unique<Worker>([&, i] { subscriberLoop(*s.readers[i], s, total, subs[i]); }));
  }
  const Nanos start = monotonicNs();
  const auto stopReaders = [&] {
    for (Peer* r : s.readers) ::shutdown(r->sock.fd(), SHUT_RDWR);
  };
  try {
    publisherLoop(s, subs, seconds, total, workers);
  } catch (...) {
    stopReaders();
    throw;
  }
  if (total.load() == std::numeric_limits<uint64_t>::max()) stopReaders();  // a reader failed
  for (auto& w : workers) w->join("subscriber");
  return summarize(subs, start, s.payload);
}

// --- rows ----------------------------------------------------------------------------------

enum class Kind { round_trip, stream };

struct Row {
  Transport transport = Transport::unix_socket;
  Kind kind = Kind::round_trip;
  size_t subscribers = 1;
  size_t payload = 0;
  Latency hub_rtt, raw_rtt;
  Throughput hub_tp, raw_tp;
};

std::string sizeText(size_t bytes) {
  if (bytes >= kMiB) return std::to_string(bytes / kMiB) + " MB";
  if (bytes >= kKiB) return std::to_string(bytes / kKiB) + " KB";
  return std::to_string(bytes) + " B";
}

std::string fmt(const char* f, double a, double b = 0) {
  char buf[96];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

std::string rateText(double per_s) {
  if (per_s >= 1e6) return fmt("%.2f M/s", per_s / 1e6);
  if (per_s >= 1e3) return fmt("%.1f k/s", per_s / 1e3);
  return fmt("%.0f /s", per_s);
}

std::string testText(const Row& r) {
  if (r.kind == Kind::round_trip) return "round trip";
  if (r.subscribers == 1) return "1:1";
  return "fan-out 1:" + std::to_string(r.subscribers);
}

std::string figureText(const Row& r, bool hub) {
  if (r.kind == Kind::round_trip) {
    const Latency& l = hub ? r.hub_rtt : r.raw_rtt;
    return fmt("p50 %.1f us  p99 %.1f us", l.p50_us, l.p99_us);
  }
  const Throughput& t = hub ? r.hub_tp : r.raw_tp;
  if (r.subscribers == 1) return rateText(t.total_rate) + fmt("  %.0f MB/s", t.mb_s);
  return rateText(t.total_rate) + " (" + rateText(t.per_sub_rate) + " per sub)";
}

std::string ratioText(const Row& r) {
  if (r.kind == Kind::round_trip) {
    return fmt("%.2fx (p99 %.2fx)", r.hub_rtt.p50_us / r.raw_rtt.p50_us,
               r.hub_rtt.p99_us / r.raw_rtt.p99_us);
  }
  return fmt("%.2fx", r.hub_tp.total_rate / r.raw_tp.total_rate);
}

void printHeader() {
  std::printf("%-5s %-12s %-6s %-31s %-31s %-19s %s\n", "", "test", "size", "hub", "raw floor",
              "hub/raw", "drops");
}

void printRow(const Row& r) {
  const std::string drops =
      r.kind == Kind::round_trip ? "-" : std::to_string(r.hub_tp.dropped + r.raw_tp.dropped);
  std::printf("%-5s %-12s %-6s %-31s %-31s %-19s %s\n", transportName(r.transport),
              testText(r).c_str(), sizeText(r.payload).c_str(), figureText(r, true).c_str(),
              figureText(r, false).c_str(), ratioText(r).c_str(), drops.c_str());
  std::fflush(stdout);
}

int roundsFor(size_t payload, bool quick) {
  const int full = payload >= 64 * kKiB ? 3000 : 20000;
  return quick ? full / 20 : full;
}

PingPair rawPingPair(Transport t) {
  PingPair p;
  if (t == Transport::tls) {
    std::tie(p.a, p.b) = rawTlsPair();
    return p;
  }
  auto [x, y] = rawPair(t);
  p.a = std::make_unique<Peer>(std::move(x));
  p.b = std::make_unique<Peer>(std::move(y));
  return p;
}

PingPair hubPingPair(const Hub& hub, Transport t) {
  PingPair p;
  p.a = loginFlow(hub, t);
  p.b = loginFlow(hub, t);
  p.chan_a = addChannel(*p.a, nextChannelName("ping"));
  p.chan_b = addChannel(*p.b, nextChannelName("pong"));
  subscribe(*p.b, p.chan_a);
  waitStartPublish(*p.a, p.chan_a);
  subscribe(*p.a, p.chan_b);
  waitStartPublish(*p.b, p.chan_b);
  return p;
}

// Raw and hub round trips alternate in blocks, so that a change in the machine's load touches
// both figures alike.
Row roundTripRow(const Hub& hub, Transport t, size_t payload, bool quick) {
  Row row{t, Kind::round_trip, 1, payload, {}, {}, {}, {}};
  const int blocks = quick ? 2 : 10;
  const int rounds = roundsFor(payload, quick) / blocks;
  const int warmup = std::max(20, rounds / 10);
  PingPair raw = rawPingPair(t);
  PingPair via_hub = hubPingPair(hub, t);
  std::vector<Nanos> raw_samples, hub_samples;
  for (int i = 0; i < blocks; ++i) {
    pingPong(raw, payload, rounds, warmup, raw_samples);
    pingPong(via_hub, payload, rounds, warmup, hub_samples);
  }
  row.raw_rtt = percentiles(raw_samples);
  row.hub_rtt = percentiles(hub_samples);
  return row;
}

Throughput rawStream(Transport t, size_t subscribers, size_t payload, double seconds) {
  std::vector<PeerPtr> ends;
  Stream s;
  for (size_t i = 0; i < subscribers; ++i) {
    if (t == Transport::tls) {
      auto [x, y] = rawTlsPair();
      ends.push_back(std::move(x));
      s.writers.push_back(ends.back().get());
      ends.push_back(std::move(y));
      s.readers.push_back(ends.back().get());
      continue;
    }
    auto [x, y] = rawPair(t);
    ends.push_back(std::make_unique<Peer>(std::move(x)));
    s.writers.push_back(ends.back().get());
    ends.push_back(std::make_unique<Peer>(std::move(y)));
    s.readers.push_back(ends.back().get());
  }
  s.chan = 1;
  s.payload = payload;
  return runStream(s, seconds);
}

Throughput hubStream(const Hub& hub, Transport t, size_t subscribers, size_t payload,
                     double seconds) {
  PeerPtr pub = loginFlow(hub, t);
  Stream s;
  s.chan = addChannel(*pub, nextChannelName("stream"));
  s.payload = payload;
  s.writers.push_back(pub.get());
  std::vector<PeerPtr> subs;
  for (size_t i = 0; i < subscribers; ++i) {
    subs.push_back(loginFlow(hub, t));
    subscribe(*subs.back(), s.chan);
    s.readers.push_back(subs.back().get());
  }
  waitStartPublish(*pub, s.chan);
  return runStream(s, seconds);
}

Row streamRow(const Hub& hub, Transport t, size_t subscribers, size_t payload, double seconds) {
  Row row{t, Kind::stream, subscribers, payload, {}, {}, {}, {}};
  row.raw_tp = rawStream(t, subscribers, payload, seconds);
  row.hub_tp = hubStream(hub, t, subscribers, payload, seconds);
  return row;
}

void runTransport(const Hub& hub, Transport t, const Options& o, std::vector<Row>& rows) {
  const auto add = [&](Row r) {
    printRow(r);
    rows.push_back(r);
  };
  const auto wanted = [&](const char* test) { return o.only.empty() || o.only == test; };
  if (wanted("round-trip")) {
    for (size_t p : {16 * size_t{1}, kKiB, 64 * kKiB}) add(roundTripRow(hub, t, p, o.quick));
  }
  if (wanted("1:1")) {
    for (size_t p : {16 * size_t{1}, kKiB, 64 * kKiB, kMiB}) {
      add(streamRow(hub, t, 1, p, o.seconds));
    }
  }
  if (wanted("fan-out")) {
    for (size_t n : {size_t{4}, size_t{16}}) {
      for (size_t p : {16 * size_t{1}, kKiB}) add(streamRow(hub, t, n, p, o.seconds));
    }
  }
}

// --- report --------------------------------------------------------------------------------

const Row* findRow(const std::vector<Row>& rows, Kind kind, size_t subs, size_t payload) {
  for (const Row& r : rows) {
    if (r.transport == Transport::unix_socket && r.kind == kind && r.subscribers == subs &&
        r.payload == payload) {
      return &r;
    }
  }
  return nullptr;
}

void printTargets(const std::vector<Row>& rows) {
  std::printf("\ntargets (unix socket):\n");
  const Row* rtt = findRow(rows, Kind::round_trip, 1, 16);
  if (rtt == nullptr) {
    std::printf("  round trip 16 B within 2.5x the raw floor: not measured\n");
  } else {
    const double ratio = rtt->hub_rtt.p50_us / rtt->raw_rtt.p50_us;
    std::printf("  round trip 16 B within 2.5x the raw floor (p50): %.2fx -> %s\n", ratio,
                ratio <= 2.5 ? "met" : "NOT met");
  }
  const Row* tp = findRow(rows, Kind::stream, 1, 16);
  if (tp == nullptr) {
    std::printf("  1:1 16 B above 3 M msg/s: not measured\n");
  } else {
    const double rate = tp->hub_tp.total_rate;
    std::printf("  1:1 16 B above 3 M msg/s: %.2f M/s -> %s\n", rate / 1e6,
                rate > 3e6 ? "met" : "NOT met");
  }
}

// Each TLS row next to the plain TCP row of the same test through the hub: what encryption costs.
void printTlsAgainstTcp(const std::vector<Row>& rows) {
  bool header = false;
  for (const Row& tls : rows) {
    if (tls.transport != Transport::tls) continue;
    const Row* tcp = nullptr;
    for (const Row& r : rows) {
      if (r.transport == Transport::tcp && r.kind == tls.kind && r.subscribers == tls.subscribers &&
          r.payload == tls.payload) {
        tcp = &r;
      }
    }
    if (tcp == nullptr) continue;
    if (!header) {
      std::printf("\nTLS against plain TCP, both through the hub:\n");
      std::printf("%-12s %-6s %-31s %-31s %s\n", "test", "size", "tls", "tcp", "tls/tcp");
      header = true;
    }
    const std::string ratio =
        tls.kind == Kind::round_trip
            ? fmt("%.2fx (p99 %.2fx)", tls.hub_rtt.p50_us / tcp->hub_rtt.p50_us,
                  tls.hub_rtt.p99_us / tcp->hub_rtt.p99_us)
            : fmt("%.2fx", tls.hub_tp.total_rate / tcp->hub_tp.total_rate);
    std::printf("%-12s %-6s %-31s %-31s %s\n", testText(tls).c_str(), sizeText(tls.payload).c_str(),
                figureText(tls, true).c_str(), figureText(*tcp, true).c_str(), ratio.c_str());
  }
}

void printPreamble(const Options& o) {
  double load[3] = {0, 0, 0};
  if (::getloadavg(load, 3) < 0) load[0] = -1;
  std::printf(
      "flow_relay: hub on its own loop thread, clients on blocking sockets; %u cpus, load %.2f\n"
      "  round trip: one message in flight, %d/%d/%d round trips at 16 B/1 KB/64 KB\n"
      "  streaming: %.2f s per figure, %zu KB per send(), %zu KB recv buffer, publisher at most "
      "%zu MB ahead\n"
      "  hub subscriber queue %zu KB, hub loop busy_poll_us %ld; MB = 2^20 bytes of payload; "
      "drops = EV_DROPPED frames\n\n",
      std::thread::hardware_concurrency(), load[0], roundsFor(16, o.quick),
      roundsFor(kKiB, o.quick), roundsFor(64 * kKiB, o.quick), o.seconds, kBatchBytes / kKiB,
      kRecvBytes / kKiB, kWindowBytes / kMiB, o.queue_bytes / kKiB, o.busy_poll_us);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseOptions(argc, argv);
  // The hub writes with libuv (write(2), no MSG_NOSIGNAL): a client that closes while the hub
  // still writes to it would otherwise kill the whole process with SIGPIPE.
  std::signal(SIGPIPE, SIG_IGN);
  skr::log::setLevel(skr::log::Level::error);  // drops are reported in the table
  try {
    std::optional<Certificates> certs;
    if (o.tls_rows && o.tcp_rows) {
      certs.emplace();
      g_certs = &*certs;
    }
    Hub hub(o, o.tcp_rows);
    std::optional<Hub> tls_hub;
    if (g_certs != nullptr) tls_hub.emplace(o, true, true);
    printPreamble(o);
    printHeader();
    std::vector<Row> rows;
    if (o.unix_rows) runTransport(hub, Transport::unix_socket, o, rows);
    if (o.tcp_rows) runTransport(hub, Transport::tcp, o, rows);
    if (tls_hub) runTransport(*tls_hub, Transport::tls, o, rows);
    flow::ServerStats st = hub.stats();
    if (tls_hub) {
      const flow::ServerStats t = tls_hub->stats();
      st.frames_in += t.frames_in;
      st.data_frames_out += t.data_frames_out;
      st.data_frames_dropped += t.data_frames_dropped;
      st.protocol_errors += t.protocol_errors + t.tls_refused;
    }
    std::printf("\nhub: %llu frames in, %llu data frames out, %llu dropped, %llu protocol errors\n",
                static_cast<unsigned long long>(st.frames_in),
                static_cast<unsigned long long>(st.data_frames_out),
                static_cast<unsigned long long>(st.data_frames_dropped),
                static_cast<unsigned long long>(st.protocol_errors));
    printTlsAgainstTcp(rows);
    printTargets(rows);
    if (st.protocol_errors != 0) fail("the hub saw protocol errors");
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "flow_relay: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
