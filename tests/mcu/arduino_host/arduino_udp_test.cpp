// SPDX-License-Identifier: Apache-2.0
// The Arduino class over UDP (satellite/mcu/src/SkRobotFlowUdp.h) on the host, against a real hub:
// the example examples/WiFiUdpPublisher/WiFiUdpPublisher.ino as written, compiled with the Debian
// Arduino core's Udp.h, IPAddress, Print, Stream and WString and this folder's Arduino.h and
// WiFiUDP (a POSIX socket), runs setup() and loop() in a thread. A satellite reads its analog
// channel, drives its PWM pin through a setpoint channel and calls its service; the hub restarts
// and the sketch logs in again.
#include "flow_fixture.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/flow/hub_stats.h>

#include <Arduino.h>
#include <SkRobotFlowUdp.h>
#include <WiFiUdp.h>

#include <atomic>
#include <thread>

void setup();
void loop();
extern SkRobotFlowUdp flow;

namespace skr::test {
namespace {

using namespace skr::flow;

constexpr UdpKey kKey = {0x00, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77,
                         0x88, 0x99, 0xaa, 0xbb, 0xcc, 0xdd, 0xee, 0xff};  // BOARD_KEY

class ArduinoUdp : public FlowFixture {
 protected:
  void start(uint16_t port = 0) {
    port_ = startUdpBoardHub(kKey, port);
    ASSERT_NE(port_, 0);
    WiFiUDP::route(HUB_PORT, port_);
  }
  void TearDown() override {
    stop_ = true;
    if (sketch_.joinable()) sketch_.join();
    FlowFixture::TearDown();
  }
  // The sketch as a board runs it: setup(), then loop() for ever.
  void run() {
    sketch_ = std::thread([this] {
      setup();
      while (!stop_) {
        loop();
        connected_ = ::flow.connected();
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    });
  }
  // Two readings of board.analog, the second later than the first.
  void expectAnalog() {
    TestClient alice = flowClient("alice", "right");
    uint16_t analog = 0;
    ASSERT_TRUE(eventually([&] { return (analog = channelId("board.analog")) != 0; }));
    ASSERT_TRUE(alice.send(msg::Subscribe{1, analog}));
    auto a = as<msg::EvData>(alice.waitFor(Code::ev_data));
    auto b = as<msg::EvData>(alice.waitFor(Code::ev_data));
    ASSERT_TRUE(a && b);
    ASSERT_EQ(a->payload.bytes.size(), 2u);
    EXPECT_NE(a->payload.bytes, b->payload.bytes);
  }

  uint16_t port_ = 0;
  std::atomic<bool> stop_{false}, connected_{false};
  std::thread sketch_;
};

TEST_F(ArduinoUdp, TheWiFiUdpPublisherExampleRunsOnAHub) {
  start();
  run();
  ASSERT_TRUE(eventually([&] { return connected_.load(); }));
  expectAnalog();

  // The setpoint (watched from the start) reaches the PWM pin.
  TestClient alice = flowClient("alice", "right");
  const uint16_t setpoint = addChannel(alice, "setpoint");
  ASSERT_TRUE(eventually([&] { return subscribersOf(setpoint) == 1; }));
  ASSERT_TRUE(alice.send(msg::Publish{setpoint, {"\x21"}}));
  ASSERT_TRUE(eventually([&] { return skr_host_last_analog_write(PWM_PIN) == 0x21; }));

  TestClient caller = syncClient("alice", "right");
  const uint16_t board = channelId("board.board");
  ASSERT_NE(board, 0);
  auto v = as<msg::ReplyValue>(caller.call(msg::ServiceCall{board, 3000, "set_pwm", Variant(200)}));
  ASSERT_TRUE(v);
  EXPECT_EQ(v->value, Variant(int64_t{200}));
  EXPECT_EQ(skr_host_last_analog_write(PWM_PIN), 200);

  // The hub restarts on the same port: a new UDP session, a new login, data again.
  const uint16_t port = port_;
  stopHub();
  start(port);
  ASSERT_TRUE(eventually([&] { return connected_.load() && channelId("board.analog") != 0; }));
  expectAnalog();
  const UdpCounters u = [&] {
    HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    return s.udp.value_or(UdpCounters{});
  }();
  EXPECT_EQ(u.stats.sessions, 1u);  // this hub's
  EXPECT_EQ(u.stats.bad_mac + u.stats.replayed + u.stats.malformed, 0u);
}

}  // namespace
}  // namespace skr::test
