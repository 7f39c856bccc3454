// SPDX-License-Identifier: Apache-2.0
// The board library's whole session over UDP (satellite/mcu/posix/skr_udp_flow.h: skr_flow.h over
// skr_udp_link.h) against a real hub (server.udp): the board publishes, subscribes and answers a
// service called by a satellite, and opens a new UDP session and logs in again when the hub
// restarts, whether the hub's CLOSE reaches it or not (then its silence does).
#include "flow_fixture.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/flow/hub_stats.h>

#include "skr_udp_flow.h"

#include <sys/socket.h>

#include <atomic>
#include <mutex>
#include <thread>

namespace skr::test {
namespace {

using namespace skr::flow;

constexpr UdpKey kKey = {3, 1, 4, 1, 5, 9, 2, 6, 5, 3, 5, 8, 9, 7, 9, 3};

// A board as a sketch would be: a loop polling the session every 2 ms, a counter published on
// board.analog every 20 ms, board.board answering (its int64 argument + 1000), and alice.setpoint
// subscribed. Its state is read by the test under `mu`; pause() holds the loop.
class UdpBoard {
 public:
  explicit UdpBoard(uint16_t port) {
    EXPECT_EQ(skr_udp_flow_open(&u_, &f_, "127.0.0.1", port, "board", kKey.data(), "udp-board"), 0);
    analog_ = skr_channel(&f_, "analog", "application/x-u16le");
    EXPECT_GE(skr_service_add(&f_, "board", onService, nullptr), 0);
    EXPECT_EQ(skr_subscribe(&f_, "alice.setpoint", onSetpoint, this), SKR_OK);
    thread_ = std::thread([this] { run(); });
  }
  ~UdpBoard() {
    stop_ = true;
    thread_.join();
    skr_udp_flow_close(&u_);
  }

  template <class F>
  auto with(F&& fn) {
    std::lock_guard lock(mu_);
    return fn(f_, u_);
  }
  bool connected() {
    return with([](skr_flow& f, skr_udp_flow&) { return skr_connected(&f) != 0; });
  }
  std::vector<std::string> setpoints() {
    std::lock_guard lock(mu_);
    return setpoints_;
  }
  std::unique_lock<std::mutex> pause() { return std::unique_lock(mu_); }
  // Reads what waits on the board's socket and throws it away (with pause() held): datagrams lost.
  int dropWaiting() {
    int n = 0;
    uint8_t d[2048];
    while (::recv(u_.fd, d, sizeof d, MSG_DONTWAIT) >= 0) ++n;
    return n;
  }

 private:
  static void onSetpoint(void* user, const uint8_t* p, size_t n) {
    static_cast<UdpBoard*>(user)->setpoints_.emplace_back(reinterpret_cast<const char*>(p), n);
  }
  static void onService(void*, const char*, size_t, const uint8_t* value, size_t value_n,
                        skr_out* answer) {
    int64_t v = 0;
    if (skr_value_int64(value, value_n, &v)) skr_put_int64(answer, v + 1000);
  }
  void run() {
    uint16_t count = 0;
    auto next = std::chrono::steady_clock::now();
    while (!stop_) {
      {
        std::lock_guard lock(mu_);
        skr_udp_flow_poll(&u_, 0);
        if (std::chrono::steady_clock::now() >= next) {
          next += std::chrono::milliseconds(20);
          ++count;
          (void)skr_publish(&f_, analog_, &count, sizeof count);
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }

  std::mutex mu_;
  skr_flow f_{};
  skr_udp_flow u_{};
  int analog_ = -1;
  std::vector<std::string> setpoints_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class UdpFlow : public FlowFixture {
 protected:
  // A hub with alice and board (with its key) and a UDP port (port 0: any; then the same again).
  void start(uint16_t port = 0) {
    port_ = startUdpBoardHub(kKey, port);
    ASSERT_NE(port_, 0);
  }

  UdpCounters udp() {
    HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    return s.udp.value_or(UdpCounters{});
  }

  // alice reads board.analog: data arrives and counts up.
  void expectAnalog() {
    TestClient alice = flowClient("alice", "right");
    uint16_t analog = 0;
    ASSERT_TRUE(eventually([&] { return (analog = channelId("board.analog")) != 0; }));
    ASSERT_TRUE(alice.send(msg::Subscribe{1, analog}));
    auto a = as<msg::EvData>(alice.waitFor(Code::ev_data));
    auto b = as<msg::EvData>(alice.waitFor(Code::ev_data));
    ASSERT_TRUE(a && b);
    ASSERT_EQ(a->payload.bytes.size(), 2u);
    uint16_t x = 0, y = 0;
    std::memcpy(&x, a->payload.bytes.data(), 2);
    std::memcpy(&y, b->payload.bytes.data(), 2);
    EXPECT_GT(y, x);
  }

  uint16_t port_ = 0;
};

TEST_F(UdpFlow, ABoardPublishesSubscribesAndAnswersAServiceOverUdp) {
  start();
  UdpBoard board(port_);
  ASSERT_TRUE(eventually([&] { return board.connected(); }));
  expectAnalog();

  // alice.setpoint appears after the board logged in: the board's watch subscribes it.
  TestClient alice = flowClient("alice", "right");
  const uint16_t setpoint = addChannel(alice, "setpoint");
  ASSERT_TRUE(eventually([&] { return subscribersOf(setpoint) == 1; }));
  ASSERT_TRUE(alice.send(msg::Publish{setpoint, {"sp-42"}}));
  ASSERT_TRUE(eventually([&] { return !board.setpoints().empty(); }));
  EXPECT_EQ(board.setpoints().front(), "sp-42");

  TestClient caller = syncClient("alice", "right");
  const uint16_t service = channelId("board.board");
  ASSERT_NE(service, 0);
  auto v = as<msg::ReplyValue>(
      caller.call(msg::ServiceCall{service, 3000, "read_adc", Variant(int64_t{5})}));
  ASSERT_TRUE(v);
  EXPECT_EQ(v->value, Variant(int64_t{1005}));

  const UdpCounters u = udp();
  EXPECT_EQ(u.stats.sessions, 1u);
  EXPECT_EQ(u.open_sessions, 1u);
  EXPECT_EQ(u.stats.bad_mac + u.stats.replayed + u.stats.malformed, 0u);
  board.with([](skr_flow& f, skr_udp_flow& uf) {
    EXPECT_EQ(skr_get_stats(&f)->logins, 1u);
    EXPECT_EQ(skr_get_stats(&f)->frames_bad, 0u);
    EXPECT_EQ(uf.link.stats.sessions, 1u);
    EXPECT_EQ(uf.link.s.stats.bad_mac, 0u);
    return 0;
  });
}

TEST_F(UdpFlow, TheBoardOpensANewSessionWhenTheHubRestarts) {
  start();
  UdpBoard board(port_);
  ASSERT_TRUE(eventually([&] { return board.connected(); }));
  const uint16_t port = port_;

  // The hub stops (its CLOSE reaches the board) and starts again on the same port.
  stopHub();
  start(port);
  ASSERT_TRUE(eventually([&] { return board.connected() && channelId("board.analog") != 0; }));
  board.with([](skr_flow& f, skr_udp_flow& uf) {
    EXPECT_EQ(uf.link.stats.closed_by_hub, 1u);
    EXPECT_EQ(uf.link.stats.sessions, 2u);
    EXPECT_EQ(skr_get_stats(&f)->logins, 2u);
    // At the CLOSE the flow stopped at once: it sent nothing until the new session opened.
    EXPECT_EQ(uf.link.stats.frames_unsent, 0u);
    return 0;
  });
  expectAnalog();

  // Again, but the CLOSE is lost (read off the board's socket while its loop is held): the board
  // sends into a session the new hub does not know, hears nothing, and starts over.
  {
    auto held = board.pause();
    stopHub();
    EXPECT_GE(board.dropWaiting(), 1);  // the CLOSE
    start(port);
  }
  ASSERT_TRUE(eventually([&] { return udp().stats.unknown_session > 0; }, 5000));
  ASSERT_TRUE(eventually([&] { return board.connected() && channelId("board.analog") != 0; },
                         SKR_SILENCE_MS + SKR_BACKOFF_MAX_MS + 5000));
  board.with([](skr_flow& f, skr_udp_flow& uf) {
    EXPECT_EQ(uf.link.stats.closed_by_hub, 1u);  // this time nothing told it
    EXPECT_EQ(uf.link.stats.sessions, 3u);
    EXPECT_EQ(skr_get_stats(&f)->logins, 3u);
    EXPECT_EQ(uf.link.stats.frames_unsent, 1u);  // the LOGIN that found the session stale
    return 0;
  });
  expectAnalog();
}

}  // namespace
}  // namespace skr::test
