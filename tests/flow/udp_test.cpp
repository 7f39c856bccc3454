// SPDX-License-Identifier: Apache-2.0
// Boards over UDP (server.udp; core/src/flow/udp_port.h): the board is the library's POSIX
// transport (satellite/mcu/posix/skr_udp.h) behind a TestClient, forged datagrams are written
// with its wire functions (skr_udp_wire.h) on a raw socket, and a seeded relay between the board
// and the hub loses and reorders datagrams. The handshake never answers an unverified peer with
// more bytes than it sent and keeps no state for it; DATA with a wrong MAC, a replayed number or
// an unknown session is dropped and counted; a silent session ends.
#include "flow_fixture.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/flow/hub_stats.h>

#include "skr_siphash.h"
#include "skr_udp.h"
#include "skr_udp_wire.h"
#include "udp_wire.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sodium.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <random>
#include <thread>

namespace skr::test {
namespace {

using namespace skr::flow;

constexpr UdpKey kBoardKey = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};

// A UDP socket on loopback: sends to a port, receives with a timeout.
struct Socket {
  int fd = -1;
  Socket() {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  }
  ~Socket() { ::close(fd); }
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;
  [[nodiscard]] uint16_t port() const {
    sockaddr_in a{};
    socklen_t len = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    return ntohs(a.sin_port);
  }
  void sendTo(uint16_t port, const uint8_t* d, size_t n) const {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(port);
    (void)::sendto(fd, d, n, 0, reinterpret_cast<sockaddr*>(&a), sizeof a);
  }
  // A datagram within timeout_ms; nullopt when none came.
  [[nodiscard]] std::optional<std::string> recv(int timeout_ms) const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return std::nullopt;
    char buf[2048];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n < 0) return std::nullopt;
    return std::string(buf, static_cast<size_t>(n));
  }
};

// Between the board and the hub: what the board sends is passed on, or dropped, or held back and
// sent after the next one (reordered), by a seeded generator, for DATA datagrams only and while
// `impair` is set; the hub's answers go back as they are.
class Relay {
 public:
  Relay(uint16_t hub_port, uint32_t seed, double drop, double reorder)
      : hub_port_(hub_port), rng_(seed), drop_(drop), reorder_(reorder) {
    thread_ = std::thread([this] { run(); });
  }
  ~Relay() {
    stop_ = true;
    thread_.join();
  }
  [[nodiscard]] uint16_t port() const { return front_.port(); }
  std::atomic<bool> impair{false};
  std::atomic<uint64_t> dropped{0}, held{0};
  std::atomic<uint64_t> forwarded{0};  // datagrams passed on to the hub

 private:
  void run() {
    sockaddr_in board{};
    socklen_t board_len = 0;
    std::optional<std::string> holding;
    while (!stop_) {
      pollfd p[2] = {{front_.fd, POLLIN, 0}, {back_.fd, POLLIN, 0}};
      if (::poll(p, 2, 20) <= 0) continue;
      char buf[2048];
      if ((p[0].revents & POLLIN) != 0) {
        board_len = sizeof board;
        const ssize_t n = ::recvfrom(front_.fd, buf, sizeof buf, 0,
                                     reinterpret_cast<sockaddr*>(&board), &board_len);
        if (n > 0) fromBoard(std::string(buf, static_cast<size_t>(n)), holding);
      }
      if ((p[1].revents & POLLIN) != 0 && board_len != 0) {
        const ssize_t n = ::recv(back_.fd, buf, sizeof buf, 0);
        if (n > 0) {
          (void)::sendto(front_.fd, buf, static_cast<size_t>(n), 0,
                         reinterpret_cast<sockaddr*>(&board), board_len);
        }
      }
    }
  }
  void fromBoard(const std::string& d, std::optional<std::string>& holding) {
    const auto pass = [&](const std::string& x) {
      back_.sendTo(hub_port_, reinterpret_cast<const uint8_t*>(x.data()), x.size());
      ++forwarded;
    };
    if (!impair || d.empty() || static_cast<uint8_t>(d[0]) != SKR_UDP_DATA) {
      pass(d);
      if (holding) pass(*std::exchange(holding, std::nullopt));
      return;
    }
    const double r = std::uniform_real_distribution<double>(0, 1)(rng_);
    if (r < drop_) {
      ++dropped;
    } else if (r < drop_ + reorder_ && !holding) {
      holding = d;
      ++held;
    } else {
      pass(d);
      if (holding) pass(*std::exchange(holding, std::nullopt));
    }
  }

  Socket front_, back_;
  uint16_t hub_port_;
  std::mt19937 rng_;
  double drop_, reorder_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class Udp : public FlowFixture {
 protected:
  // A hub with alice (password "right") and board (with a UDP key), and a UDP port.
  void start(uint32_t session_timeout_ms = 10000) {
    auto o = defaults();
    o.users_file = dir_.path() / "users.json";
    auto users = UsersFile::load(o.users_file);
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->add("alice", "right"));
    ASSERT_TRUE(users->add("board", "board-secret"));
    ASSERT_TRUE(users->add("keyless", "secret"));
    ASSERT_TRUE(users->setUdpKey("board", kBoardKey));
    ASSERT_TRUE(users->save());
    transport::UdpOptions udp;
    udp.address = "127.0.0.1";
    udp.port = 0;
    udp.max_datagram = 512;
    udp.session_timeout_ms = session_timeout_ms;
    o.udp = udp;
    ASSERT_TRUE(startHub(o));
    onHub([&] { port_ = server_->udpPort(); });
    ASSERT_NE(port_, 0);
  }

  TestClient board(uint16_t port = 0) {
    auto b = TestClient::overUdp("127.0.0.1", port == 0 ? port_ : port, "board", kBoardKey);
    EXPECT_TRUE(b) << b.error().message;
    return b ? std::move(b).value() : TestClient();
  }

  // LOGIN, SESSION_LIMITS, GO_ASYNC: a small session as a board opens it.
  void smallSession(TestClient& b, const std::string& watch) {
    auto ok = b.login("board", "");
    ASSERT_TRUE(ok) << ok.error().message;
    EXPECT_EQ(ok->user, "board");
    auto r = b.call(msg::SessionLimits{494, 0, watch});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->kind(), Code::reply_ok);
    r = b.call(msg::GoAsync{});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->kind(), Code::reply_ok);
  }

  UdpCounters udp() {
    HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    EXPECT_TRUE(s.udp.has_value());
    return s.udp.value_or(UdpCounters{});
  }

  uint16_t port_ = 0;
};

TEST_F(Udp, ABoardLogsInPublishesSubscribesAndAnswersAServiceCall) {
  start();
  TestClient b = board();
  smallSession(b, "alice.setpoint");
  TestClient alice = flowClient("alice", "right");
  const uint16_t setpoint = addChannel(alice, "setpoint");
  auto ev = as<msg::EvChanAdded>(b.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->info.id, setpoint);

  // Its own channel; alice subscribes and gets its data.
  msg::ChanAdd add;
  add.tag = 5;
  add.kind = static_cast<uint8_t>(ChannelKind::streaming);
  add.short_name = "analog";
  add.props = Variant(Variant::Map{});
  ASSERT_TRUE(b.send(add));
  ev = as<msg::EvChanAdded>(b.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->info.name, "board.analog");
  const uint16_t analog = ev->info.id;
  ASSERT_TRUE(alice.send(msg::Subscribe{1, analog}));
  ASSERT_TRUE(b.waitFor(Code::ev_start_publish));
  ASSERT_TRUE(b.send(msg::Publish{analog, {"\x12\x34"}}));
  auto data = as<msg::EvData>(alice.waitFor(Code::ev_data));
  ASSERT_TRUE(data);
  EXPECT_EQ(data->payload.bytes, "\x12\x34");

  // What it subscribes to reaches it.
  ASSERT_TRUE(b.send(msg::Subscribe{2, setpoint}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(setpoint) == 1; }));
  ASSERT_TRUE(alice.send(msg::Publish{setpoint, {"small"}}));
  data = as<msg::EvData>(b.waitFor(Code::ev_data));
  ASSERT_TRUE(data);
  EXPECT_EQ(data->payload.bytes, "small");

  // A service on the board, called by alice.
  add.tag = 6;
  add.kind = static_cast<uint8_t>(ChannelKind::service);
  add.short_name = "set_pwm";
  ASSERT_TRUE(b.send(add));
  ev = as<msg::EvChanAdded>(b.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(ev);
  const uint16_t pwm = ev->info.id;
  TestClient caller = syncClient("alice", "right");
  ASSERT_TRUE(caller.send(msg::ServiceCall{pwm, 3000, "set", Variant(int64_t{42})}));
  auto req = as<msg::EvServiceRequest>(b.waitFor(Code::ev_service_request));
  ASSERT_TRUE(req);
  EXPECT_EQ(req->command, "set");
  ASSERT_TRUE(b.send(msg::ServiceResponse{pwm, req->request, Variant("done")}));
  auto reply = caller.recvReply();
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->kind(), Code::reply_ok);

  const UdpCounters u = udp();
  EXPECT_EQ(u.stats.sessions, 1u);
  EXPECT_EQ(u.open_sessions, 1u);
  EXPECT_EQ(u.stats.cookies_sent, 1u);
  EXPECT_EQ(u.stats.bad_mac + u.stats.replayed + u.stats.lost + u.stats.malformed, 0u);
}

TEST_F(Udp, TheSessionsAccountLogsInAndBlobsAreRefused) {
  start();
  TestClient other = board();
  EXPECT_FALSE(other.login("alice", "right"));  // the key is board's: no other account
  TestClient b = board();
  auto ok = b.login("", "");
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->user, "board");
  auto r = b.call(msg::BlobList{1, ""});
  ASSERT_TRUE(r);
  auto err = as<msg::ReplyError>(r);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::unsupported));
  // A reply that no datagram carries (max_datagram 512) is refused, not lost.
  TestClient alice = flowClient("alice", "right");
  for (int i = 0; i < 12; ++i) addChannel(alice, "a-rather-long-channel-name-" + std::to_string(i));
  r = b.call(msg::ChanList{});
  ASSERT_TRUE(r);
  err = as<msg::ReplyError>(r);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::limit_exceeded));
  // A keyless account opens no session.
  EXPECT_FALSE(TestClient::overUdp("127.0.0.1", port_, "keyless", kBoardKey));
  EXPECT_GE(udp().stats.bad_mac, 1u);
}

TEST_F(Udp, TheHandshakeNeverAnswersWithMoreThanItGotAndKeepsNoState) {
  start();
  Socket raw;
  skr_udp_session s;
  skr_udp_init(&s, kBoardKey.data());
  const uint8_t nonce[8] = {9, 9, 9, 9, 9, 9, 9, 9};
  uint8_t hello[128];
  const size_t n = skr_udp_make_hello(&s, "board", nonce, hello, sizeof hello);
  ASSERT_EQ(n, 64u);
  // Short of 64 bytes: nothing.
  raw.sendTo(port_, hello, 63);
  EXPECT_FALSE(raw.recv(300));
  // 64 bytes: a COOKIE of 26.
  raw.sendTo(port_, hello, n);
  auto answer = raw.recv(2000);
  ASSERT_TRUE(answer);
  EXPECT_LE(answer->size(), n);
  uint8_t cookie[16];
  ASSERT_TRUE(skr_udp_take_cookie(&s, reinterpret_cast<const uint8_t*>(answer->data()),
                                  answer->size(), cookie));
  EXPECT_EQ(udp().open_sessions, 0u);  // a HELLO leaves nothing behind

  // An OPEN with a cookie the hub did not give: nothing.
  uint8_t open[128];
  uint8_t forged[16] = {};
  size_t m = skr_udp_make_open(&s, "board", forged, open, sizeof open);
  raw.sendTo(port_, open, m);
  EXPECT_FALSE(raw.recv(300));
  // The right cookie and the wrong key: nothing.
  skr_udp_session wrong;
  const uint8_t other_key[16] = {7};
  skr_udp_init(&wrong, other_key);
  std::memcpy(wrong.client_nonce, nonce, 8);
  m = skr_udp_make_open(&wrong, "board", cookie, open, sizeof open);
  raw.sendTo(port_, open, m);
  EXPECT_FALSE(raw.recv(300));
  // The right key: ACCEPT, and the same again for a repeated OPEN (its answer was lost).
  m = skr_udp_make_open(&s, "board", cookie, open, sizeof open);
  raw.sendTo(port_, open, m);
  auto accept = raw.recv(2000);
  ASSERT_TRUE(accept);
  raw.sendTo(port_, open, m);
  auto again = raw.recv(2000);
  ASSERT_TRUE(again);
  EXPECT_EQ(*again, *accept);
  EXPECT_TRUE(
      skr_udp_take_accept(&s, reinterpret_cast<const uint8_t*>(accept->data()), accept->size()));
  EXPECT_EQ(udp().open_sessions, 1u);
  // Once that session ended, the same OPEN is a replay: no new session.
  m = skr_udp_make_close(&s, open, sizeof open);
  raw.sendTo(port_, open, m);
  ASSERT_TRUE(eventually([&] { return udp().open_sessions == 0; }));
  m = skr_udp_make_open(&s, "board", cookie, open, sizeof open);
  raw.sendTo(port_, open, m);
  EXPECT_FALSE(raw.recv(300));
  const UdpCounters u = udp();
  EXPECT_EQ(u.stats.short_hello, 1u);
  EXPECT_EQ(u.stats.cookies_sent, 1u);
  EXPECT_EQ(u.stats.bad_cookie, 1u);
  EXPECT_EQ(u.stats.bad_mac, 1u);
  EXPECT_EQ(u.stats.sessions, 1u);
  EXPECT_EQ(u.stats.replayed, 1u);
  EXPECT_EQ(u.open_sessions, 0u);
}

TEST_F(Udp, ForgedAndReplayedDatagramsAreDroppedAndCounted) {
  start();
  TestClient b = board();
  ASSERT_TRUE(b.login("", ""));
  skr_udp* u = b.udp();
  Socket raw;
  uint8_t d[128];
  const std::string ping = [] {
    std::string out;
    EXPECT_TRUE(encode(out, msg::Ping{{"forged"}}));
    return out;
  }();
  const auto* frame = reinterpret_cast<const uint8_t*>(ping.data());

  // A wrong MAC (another session key).
  skr_udp_session forged = u->s;
  forged.session_key[0] ^= 1;
  size_t n = skr_udp_make_data(&forged, frame, ping.size(), d, sizeof d);
  raw.sendTo(port_, d, n);
  // A replay: the board's first number again, with the right key.
  skr_udp_session replay = u->s;
  replay.seq_out = 0;
  n = skr_udp_make_data(&replay, frame, ping.size(), d, sizeof d);
  raw.sendTo(port_, d, n);
  // An unknown session.
  skr_udp_session unknown = u->s;
  unknown.session ^= 0x5a5a5a5a;
  n = skr_udp_make_data(&unknown, frame, ping.size(), d, sizeof d);
  raw.sendTo(port_, d, n);
  // None of them was answered; the board's own request is.
  EXPECT_FALSE(raw.recv(300));
  auto r = b.call(msg::Ping{{"real"}});
  ASSERT_TRUE(r);
  auto pong = as<msg::Pong>(r);
  ASSERT_TRUE(pong);
  EXPECT_EQ(pong->echo.bytes, "real");
  EXPECT_FALSE(b.recv(200));  // no second PONG: nothing forged went through
  const UdpCounters c = udp();
  EXPECT_EQ(c.stats.bad_mac, 1u);
  EXPECT_EQ(c.stats.replayed, 1u);
  EXPECT_EQ(c.stats.unknown_session, 1u);
}

TEST_F(Udp, AFloodOfForgedHellosAndOpensLeavesTheHubAnsweringABoard) {
  start();
  const char* env = std::getenv("UDP_FLOOD");
  const int kFlood = env != nullptr ? std::atoi(env) : 4000;
  Socket raw;
  std::mt19937 rng(41);
  uint8_t d[128];
  for (int i = 0; i < kFlood; ++i) {
    skr_udp_session s;
    uint8_t key[16], nonce[8], cookie[16];
    for (auto& x : key) x = static_cast<uint8_t>(rng());
    for (auto& x : nonce) x = static_cast<uint8_t>(rng());
    for (auto& x : cookie) x = static_cast<uint8_t>(rng());
    skr_udp_init(&s, key);
    size_t n = skr_udp_make_hello(&s, "board", nonce, d, sizeof d);
    raw.sendTo(port_, d, n);
    n = skr_udp_make_open(&s, "board", cookie, d, sizeof d);
    raw.sendTo(port_, d, n);
    if (i % 64 == 0) {
      while (raw.recv(0)) {
      }
    }
  }
  TestClient b = board();
  auto ok = b.login("", "");
  ASSERT_TRUE(ok) << ok.error().message;
  const UdpCounters u = udp();
  EXPECT_EQ(u.open_sessions, 1u);  // nothing kept for the forged peers
  EXPECT_EQ(u.stats.sessions, 1u);
  EXPECT_GT(u.stats.bad_cookie, 0u);
  EXPECT_GT(u.stats.cookies_sent, 0u);
  EXPECT_LE(u.stats.bytes_out, u.stats.bytes_in);  // no amplification, flood and board together
}

TEST_F(Udp, LossAndReorderingThroughARelayAreCounted) {
  start();
  Relay relay(port_, 7, 0.1, 0.1);
  TestClient b = board(relay.port());
  ASSERT_TRUE(b.login("", ""));
  relay.impair = true;
  constexpr int kPings = 300;
  int pongs = 0;
  for (int i = 0; i < kPings; ++i) {
    ASSERT_TRUE(b.send(msg::Ping{{std::to_string(i)}}));
    if (i % 20 == 19) {
      // A batch at a time: the hub has read what the relay passed on, and the board reads the
      // answers, so that no socket's buffer (a few hundred datagrams) overflows on a busy host.
      ASSERT_TRUE(eventually([&] { return udp().stats.datagrams_in == relay.forwarded; }));
      while (auto f = b.recv(0)) pongs += f->kind() == Code::reply_ok ? 1 : 0;
    }
  }
  relay.impair = false;
  // The last one passes and releases any held back; its answer comes after the others.
  auto r = b.call(msg::Ping{{"last"}});
  ASSERT_TRUE(r);
  for (;;) {
    auto pong = as<msg::Pong>(r);
    ASSERT_TRUE(pong);
    if (pong->echo.bytes == "last") break;
    ++pongs;
    r = b.recvReply(2000);
    const UdpCounters c = udp();
    ASSERT_TRUE(r) << pongs << " answers; dropped " << relay.dropped << ", held " << relay.held
                   << "; hub: in " << c.stats.datagrams_in << ", out " << c.stats.datagrams_out
                   << ", lost " << c.stats.lost << ", reordered " << c.stats.reordered
                   << ", overrun " << c.stats.overrun << ", send_failed " << c.stats.send_failed
                   << "; board: lost " << b.udp()->s.stats.lost << ", other "
                   << b.udp()->s.stats.other;
  }
  EXPECT_GT(relay.dropped.load(), 0u);
  EXPECT_GT(relay.held.load(), 0u);
  EXPECT_EQ(pongs, kPings - static_cast<int>(relay.dropped.load()));
  const UdpCounters u = udp();
  EXPECT_EQ(u.stats.lost, relay.dropped.load());
  EXPECT_EQ(u.stats.reordered, relay.held.load());
  EXPECT_EQ(u.stats.replayed, 0u);
}

TEST_F(Udp, ASilentSessionEnds) {
  start(300);
  TestClient b = board();
  ASSERT_TRUE(b.login("", ""));
  ASSERT_TRUE(eventually([&] { return udp().stats.timeouts == 1; }, 5000));
  EXPECT_EQ(udp().open_sessions, 0u);
  // The hub said so (CLOSE): the board's transport reports the end.
  const uint8_t* f = nullptr;
  size_t n = 0;
  EXPECT_EQ(skr_udp_poll(b.udp(), 1000, &f, &n), -1);
}

// The board's SipHash against libsodium's, and its replay window against the hub's.
TEST(UdpWire, TheBoardsSipHashAndWindowAreTheHubs) {
  ASSERT_TRUE(sodiumReady());
  std::mt19937 rng(3);
  udp::Key key{};
  for (auto& x : key) x = static_cast<uint8_t>(rng());
  std::string msg;
  for (size_t n = 0; n < 300; ++n) {
    uint8_t out8[8], out16[16];
    skr_siphash(key.data(), reinterpret_cast<const uint8_t*>(msg.data()), msg.size(), out8, 8);
    skr_siphash(key.data(), reinterpret_cast<const uint8_t*>(msg.data()), msg.size(), out16, 16);
    const udp::Mac64 m8 = udp::mac64(key, msg);
    const udp::Key m16 = udp::mac128(key, msg);
    ASSERT_EQ(std::memcmp(out8, m8.data(), 8), 0) << n;
    ASSERT_EQ(std::memcmp(out16, m16.data(), 16), 0) << n;
    // Incrementally, in two pieces.
    skr_siphash_ctx c;
    skr_siphash_init(&c, key.data(), 16);
    skr_siphash_update(&c, reinterpret_cast<const uint8_t*>(msg.data()), n / 3);
    skr_siphash_update(&c, reinterpret_cast<const uint8_t*>(msg.data()) + n / 3, n - n / 3);
    skr_siphash_final(&c, out16);
    ASSERT_EQ(std::memcmp(out16, m16.data(), 16), 0) << n;
    msg.push_back(static_cast<char>(rng()));
  }
  uint32_t hi = 0;
  uint64_t win = 0;
  skr_udp_stats st{};
  udp::ReplayWindow w;
  uint64_t lost = 0;
  for (int i = 0; i < 5000; ++i) {
    const uint32_t seq = 1 + rng() % 400 + static_cast<uint32_t>(i / 10);
    const int board = skr_udp_window(&hi, &win, &st, seq);
    const auto hub = w.take(seq, lost);
    ASSERT_EQ(board == 1, hub != udp::ReplayWindow::Verdict::replayed) << i;
  }
  EXPECT_EQ(st.lost, lost);
  EXPECT_GT(st.replayed, 0u);
  EXPECT_GT(st.reordered, 0u);
}

// A DATA the board makes is what the hub reads, and the other way round.
TEST(UdpWire, BothEndsReadWhatTheOtherWrites) {
  udp::Key key{};
  key[3] = 7;
  skr_udp_session s;
  skr_udp_init(&s, key.data());
  const uint8_t nonce[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  uint8_t d[128];
  ASSERT_EQ(skr_udp_make_hello(&s, "board", nonce, d, sizeof d), 64u);
  auto hello = udp::parseHello({reinterpret_cast<const char*>(d), 64});
  ASSERT_TRUE(hello);
  EXPECT_EQ(hello->user, "board");
  const udp::Nonce server{9, 8, 7, 6, 5, 4, 3, 2};
  const std::string accept = udp::makeAccept(key, hello->nonce, 77, server);
  ASSERT_TRUE(
      skr_udp_take_accept(&s, reinterpret_cast<const uint8_t*>(accept.data()), accept.size()));
  EXPECT_EQ(s.session, 77u);
  const udp::Key session_key = udp::sessionKey(key, hello->nonce, server);
  EXPECT_EQ(std::memcmp(s.session_key, session_key.data(), 16), 0);
  const uint8_t frame[6] = {2, 0, 0, 0, 0x30, 1};
  const size_t n = skr_udp_make_data(&s, frame, sizeof frame, d, sizeof d);
  auto m = udp::parseNumbered({reinterpret_cast<const char*>(d), n});
  ASSERT_TRUE(m);
  EXPECT_EQ(m->seq, 1u);
  EXPECT_TRUE(udp::wholeFrame(m->frame));
  EXPECT_EQ(udp::mac64(session_key, m->signed_part), m->mac);
  const std::string back = udp::makeNumbered(udp::Type::data, session_key, 77, 1, m->frame);
  size_t off = 0, len = 0;
  EXPECT_EQ(
      skr_udp_take(&s, reinterpret_cast<const uint8_t*>(back.data()), back.size(), &off, &len),
      SKR_UDP_RX_DATA);
  EXPECT_EQ(len, sizeof frame);
  EXPECT_EQ(
      skr_udp_take(&s, reinterpret_cast<const uint8_t*>(back.data()), back.size(), &off, &len),
      SKR_UDP_RX_NONE);  // the same number again
  EXPECT_EQ(s.stats.replayed, 1u);
}

}  // namespace
}  // namespace skr::test
