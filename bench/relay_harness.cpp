// SPDX-License-Identifier: Apache-2.0
// The relay benchmark's harness (relay_harness.h): the hub, its clients, round trips and streams.
#include "relay_harness.h"

#include <skrobot/hub/flow/accounts.h>

#include <arpa/inet.h>
#include <netinet/tcp.h>
#include <sys/un.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <tuple>

namespace skr::bench {

using flow::Code;

const char* transportName(Transport t) {
  return t == Transport::tls ? "tls" : t == Transport::tcp ? "tcp" : "unix";
}

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

Certificates::Certificates() {
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

const Certificates* g_certs = nullptr;

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

[[noreturn]] void failOnEvError(const FrameView& f, const char* during) {
  const auto e = decodeOrFail<msg::EvError>(f);
  fail(std::string("EV_ERROR during ") + during + ": " +
       std::string(flow::errorCodeName(flow::ErrorCode(e.error))) + ", " + e.message);
}

Hub::Hub(const HubOptions& o) {
  flow::ServerOptions so;
  so.app_name = "skrobot-bench-" + std::to_string(::getpid());
  so.unix_path = (dir_.path() / "hub.sock").string();
  so.users_file = dir_.path() / "users.json";
  so.dev_account = std::make_pair(std::string("guest"), std::string("password"));
  so.subscriber_queue_bytes = o.queue_bytes;
  if (o.tcp || o.tls) {
    so.tcp_enabled = true;
    so.tcp_port = 0;
    createAccount(so.users_file);
  }
  if (o.tls) {
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
    // As the hub runs it (core/app/main.cpp): its one-second work is part of what is measured.
    if (r) stats_ = std::make_unique<flow::HubStats>(thread_->loop(), *server_);
  });
  if (!r) {
    thread_->loop().invoke([&] { server_.reset(); });
    fail("hub start: " + r.error().describe());
  }
}

Hub::~Hub() {
  thread_->loop().invoke([&] {
    stats_.reset();
    server_.reset();
  });
  thread_.reset();
}

PeerPtr Hub::dial(Transport t) const {
  if (t == Transport::unix_socket) return std::make_unique<Peer>(connectUnix(unix_path_));
  Socket s = connectTcp(tcp_port_);
  if (t == Transport::tcp) return std::make_unique<Peer>(std::move(s));
  flow::TlsSession session = clientHandshake(s.fd());
  return std::make_unique<Peer>(std::move(s), std::move(session));
}

flow::ServerStats Hub::stats() {
  flow::ServerStats s;
  thread_->loop().invoke([&] { s = server_->stats(); });
  return s;
}

void Hub::createAccount(const std::filesystem::path& path) {
  auto users = flow::UsersFile::load(path);
  if (!users) fail("users file: " + users.error().describe());
  if (auto r = users->add(kTcpUser, kTcpPassword); !r) fail("add user: " + r.error().describe());
  if (auto r = users->save(); !r) fail("save users: " + r.error().describe());
}

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
  m.client_name = "bench";
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

// --- round trip ----------------------------------------------------------------------------

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

namespace {

// What one subscriber thread saw; `seen` (received + dropped) paces the publisher.
struct alignas(64) SubStats {
  std::atomic<uint64_t> seen{0};
  uint64_t received = 0;
  uint64_t dropped = 0;  // announced by EV_DROPPED
  uint64_t gaps = 0;     // missing sequence numbers
  Nanos last_ns = 0;     // when the last data frame arrived
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

Batch makeBatch(uint16_t chan, size_t payload, size_t batch_bytes) {
  const size_t frame = kDataOverhead + payload;
  const size_t frames = std::max<size_t>(1, batch_bytes / frame);
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
  Batch batch = makeBatch(s.chan, s.payload, s.batch_bytes);
  const uint64_t k = batch.offsets.size();
  const uint64_t window = std::max<uint64_t>(2 * k, s.window_bytes / (kDataOverhead + s.payload));
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

}  // namespace

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

std::string sizeText(size_t bytes) {
  if (bytes >= kMiB) return std::to_string(bytes / kMiB) + " MB";
  if (bytes >= kKiB) return std::to_string(bytes / kKiB) + " KB";
  return std::to_string(bytes) + " B";
}

std::string fmt(const char* f, double a, double b) {
  char buf[96];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

std::string rateText(double per_s) {
  if (per_s >= 1e6) return fmt("%.2f M/s", per_s / 1e6);
  if (per_s >= 1e3) return fmt("%.1f k/s", per_s / 1e3);
  return fmt("%.0f /s", per_s);
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
                     double seconds, size_t batch_bytes, size_t window_bytes) {
  PeerPtr pub = loginFlow(hub, t);
  Stream s;
  s.chan = addChannel(*pub, nextChannelName("stream"));
  s.payload = payload;
  s.batch_bytes = batch_bytes;
  s.window_bytes = window_bytes;
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

}  // namespace skr::bench
