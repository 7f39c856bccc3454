// SPDX-License-Identifier: Apache-2.0
// A real Arduino sketch (satellite/mcu/examples/AnalogPublisher, built for the Uno with the board
// library) in simavr, on a real hub's serial port: it publishes its analog reading at 50 Hz,
// follows a sync source, answers `flowctl call`, takes a setpoint, and is read by a C++ and a
// Python satellite; reset in the middle, it logs in again and nothing of it is left behind; on a
// noisy line the hub and the board resynchronise; a port that goes away is reopened.
#include "hub_process.h"
#include "sat_fixture.h"
#include "sim_board.h"

#include <gtest/gtest.h>

#include <string>

namespace skr::sat::test {
namespace {

using skr::boards::test::LineRelay;
using skr::boards::test::SimBoard;
using skr::test::TempDir;

// The hub with the account "robot" (the sketch's user), its serial port bound to it.
std::unique_ptr<HubProcess> hubOn(const fs::path& dir, const std::string& device,
                                  uint32_t baud = 115200) {
  return std::make_unique<HubProcess>(SKROBOT_BIN, dir, "robot",
                                      R"(, "serial": [{"device": ")" + device +
                                          R"(", "account": "robot", "baud": )" +
                                          std::to_string(baud) + "}]");
}

// flowctl against the hub of `dir`; its output.
std::string flowctl(const fs::path& dir, std::vector<std::string> args, int* code = nullptr) {
  args.insert(args.begin(), {FLOWCTL_BIN, "--address", "local:" + (dir / "hub.sock").string()});
  static int n = 0;
  const fs::path out = dir / ("flowctl-" + std::to_string(++n) + ".log");
  Child c(args, {}, out);
  const int rc = c.wait(20000);
  if (code != nullptr) *code = rc;
  return c.output();
}

class Board : public SatTest {
 protected:
  // A C++ satellite of guest's that reads robot.analog and owns guest.setpoint.
  std::unique_ptr<SatOnThread> reader() {
    auto s = satellite("reader");
    EXPECT_TRUE(s->on([](Satellite& x) { return x.addChannel({.name = "setpoint"}); }));
    s->on([](Satellite& x) { x.subscribe("robot.analog"); });
    return s;
  }
  size_t analogCount(SatOnThread& s) { return s.events.count("data:robot.analog:"); }
};

TEST_F(Board, TheExampleSketchPublishesAnswersFollowsAndComesBackAfterAReset) {
  SimBoard board(SIMAVR_RUNNER_BIN, ANALOG_PUBLISHER_ELF, dir_.path());
  ASSERT_FALSE(board.pty().empty()) << board.output();
  hub_ = hubOn(dir_.path(), board.pty());
  startHub();
  auto cpp = reader();
  // The board logs in, creates robot.analog and publishes at 50 Hz of simulated time.
  ASSERT_TRUE(eventually([&] { return analogCount(*cpp) >= 20; }, 30000))
      << cpp->events.dump() << hubLog() << board.output()
      << (hubStats() ? flow::variantToJsonText(*hubStats()) : std::string("no stats"));

  // A Python satellite reads it too.
  const fs::path py_out = dir_.path() / "python.log";
  Child python({"/usr/bin/python3", PYTHON_SUBSCRIBER, "robot.analog", "10"},
               {"PYTHONPATH=" PYSKETCH_DIR, "ROBOT_ADDRESS=" + address()}, py_out);
  EXPECT_EQ(python.wait(30000), 0) << python.output() << hubLog();
  EXPECT_NE(python.output().find("10 values of 2 bytes"), std::string::npos) << python.output();

  // Its service, through flowctl call.
  EXPECT_NE(flowctl(dir_.path(), {"call", "robot.board", "set_pwm", "128"}).find("128"),
            std::string::npos);
  const std::string adc = flowctl(dir_.path(), {"call", "robot.board", "read_adc", "0"});
  EXPECT_NE(adc.find_first_of("0123456789"), std::string::npos) << adc;
  // Its channel described in its flow's database.
  // A sync source it follows: it counts the steps.
  Child pulse({FLOWCTL_BIN, "--address", address(), "sync", "source", "pulse", "--hz", "20"}, {},
              dir_.path() / "pulse.log");
  ASSERT_TRUE(eventually(
      [&] {
        const std::string steps = flowctl(dir_.path(), {"call", "robot.board", "steps", "0"});
        return steps.find_first_of("123456789") != std::string::npos;
      },
      30000))
      << hubLog() << pulse.output();
  // The setpoint reaches it (set_pwm above answered; the setpoint is taken without an answer).
  ASSERT_TRUE(cpp->on([](Satellite& s) { return s.publish("setpoint", std::string(1, '\x40')); }));

  // Reset in the middle: it logs in again, its old session is gone, data resumes.
  const size_t before = analogCount(*cpp);
  board.reset();
  ASSERT_TRUE(eventually([&] { return cpp->events.count("removed:robot.analog") >= 1; }, 20000))
      << cpp->events.dump() << hubLog();
  ASSERT_TRUE(eventually([&] { return analogCount(*cpp) >= before + 20; }, 30000))
      << hubLog() << board.output();
  auto stats = hubStats();
  ASSERT_TRUE(stats);
  size_t analog_channels = 0, robot_flows = 0;
  for (const flow::Variant& c : *stats->find("channels")->asList()) {
    if (*c.find("name")->asString() == "robot.analog") ++analog_channels;
  }
  for (const flow::Variant& f : *stats->find("flows")->asList()) {
    if (*f.find("user")->asString() == "robot") ++robot_flows;
  }
  EXPECT_EQ(analog_channels, 1u);
  EXPECT_EQ(robot_flows, 1u) << flow::variantToJsonText(*stats);
  const flow::Variant& port = (*stats->find("serial")->asList())[0];
  EXPECT_EQ(*port.find("device")->asString(), board.pty());
  EXPECT_GE(port.find("sessions")->asInt64(), 2);

  // flowctl top shows the line.
  const std::string top = flowctl(dir_.path(), {"top", "--once"});
  EXPECT_NE(top.find("SERIAL PORT"), std::string::npos) << top;
  EXPECT_NE(top.find(board.pty()), std::string::npos) << top;
}

// docs/microcontrollers.md's first sketch, as written there: its counter and its LED service.
TEST_F(Board, TheFirstSketchOfTheDocsRunsAsWritten) {
  SimBoard board(SIMAVR_RUNNER_BIN, FIRST_SKETCH_ELF, dir_.path());
  ASSERT_FALSE(board.pty().empty()) << board.output();
  hub_ = hubOn(dir_.path(), board.pty());
  startHub();
  auto s = satellite("reader");
  s->on([](Satellite& x) { x.subscribe("robot.counter"); });
  ASSERT_TRUE(eventually([&] { return s->events.count("data:robot.counter:") >= 10; }, 30000))
      << hubLog() << board.output();
  EXPECT_NE(flowctl(dir_.path(), {"call", "robot.led", "on"}).find("on"), std::string::npos);
  const std::string off = flowctl(dir_.path(), {"call", "robot.led", "off"});
  EXPECT_NE(off.find("off"), std::string::npos) << off;
}

// At 1,000,000 baud the hub's answers come faster than an Uno reads them while it writes: the
// board adds its channels one at a time, so that their answers never overflow its receive buffer
// (before: the answers to its two CHAN_ADDs were lost together, and the board, logged in, never
// published nor answered).
TEST_F(Board, AOneMegabaudBoardAnswersItsServiceAndPublishes) {
  SimBoard board(SIMAVR_RUNNER_BIN, ANALOG_PUBLISHER_1000000_ELF, dir_.path());
  ASSERT_FALSE(board.pty().empty()) << board.output();
  hub_ = hubOn(dir_.path(), board.pty(), 1000000);
  startHub();
  auto cpp = reader();
  const auto line = [&] {
    auto stats = hubStats();
    return stats ? flow::variantToJsonText((*stats->find("serial")->asList())[0])
                 : std::string("no stats");
  };
  ASSERT_TRUE(eventually([&] { return analogCount(*cpp) >= 10; }, 15000))
      << cpp->events.dump() << hubLog() << line();
  const std::string answer = flowctl(dir_.path(), {"call", "robot.board", "set_pwm", "77"});
  EXPECT_NE(answer.find("77"), std::string::npos) << answer << line();
}

TEST_F(Board, ANoisyLineIsResynchronisedAndDataGoesOn) {
  SimBoard board(SIMAVR_RUNNER_BIN, ANALOG_PUBLISHER_ELF, dir_.path());
  ASSERT_FALSE(board.pty().empty()) << board.output();
  LineRelay relay(LINE_RELAY_BIN, board.pty(), dir_.path(),
                  {"--baud", "115200", "--seed", "7", "--error-rate", "0.002"});
  ASSERT_FALSE(relay.pty().empty()) << relay.output();
  hub_ = hubOn(dir_.path(), relay.pty());
  startHub();
  auto cpp = reader();
  ASSERT_TRUE(eventually([&] { return analogCount(*cpp) >= 100; }, 60000))
      << hubLog() << relay.output();
  auto stats = hubStats();
  ASSERT_TRUE(stats);
  const flow::Variant& port = (*stats->find("serial")->asList())[0];
  EXPECT_GT(port.find("resyncs")->asInt64(), 0) << flow::variantToJsonText(port);
  relay.stop();
  EXPECT_NE(relay.output().find("flipped"), std::string::npos) << relay.output();
}

TEST_F(Board, APortThatGoesAwayIsReopenedWhenItComesBack) {
  SimBoard board(SIMAVR_RUNNER_BIN, ANALOG_PUBLISHER_ELF, dir_.path());
  ASSERT_FALSE(board.pty().empty()) << board.output();
  const fs::path link = dir_.path() / "ttyBOARD";
  LineRelay relay(LINE_RELAY_BIN, board.pty(), dir_.path(),
                  {"--link", link.string(), "--unplug-at-ms", "3000", "--replug-after-ms", "1500"});
  ASSERT_FALSE(relay.pty().empty()) << relay.output();
  hub_ = hubOn(dir_.path(), (dir_.path() / "ttyBOARD*").string());
  startHub();
  auto cpp = reader();
  ASSERT_TRUE(eventually([&] { return analogCount(*cpp) >= 10; }, 30000)) << hubLog();
  ASSERT_TRUE(eventually([&] { return hubLog().find("SERIAL-LOST") != std::string::npos; }, 20000))
      << hubLog() << relay.output();
  const size_t before = analogCount(*cpp);
  ASSERT_TRUE(eventually([&] { return analogCount(*cpp) >= before + 10; }, 30000))
      << hubLog() << relay.output();
}

}  // namespace
}  // namespace skr::sat::test
