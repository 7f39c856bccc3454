// SPDX-License-Identifier: Apache-2.0
// The hub's supervised satellites (docs/robot.md) as a user sees them: a real hub with a
// "satellites" section, its log, flowctl ps/start/stop/restart/logs, and the processes themselves.
#include "supervised_hub.h"

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/satellite.h>

#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <cerrno>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace {

using skr::flow::Variant;
using skr::sat::test::eventually;
using skr::sat::test::SupervisedHub;
using skr::sat::test::TempDir;
namespace fs = std::filesystem;

// A process that is gone, or a zombie waiting for a parent that is not ours to wait.
bool gone(pid_t pid) {
  if (::kill(pid, 0) != 0 && errno == ESRCH) return true;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string all((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const size_t paren = all.rfind(')');
  return paren == std::string::npos || all.substr(paren + 2, 1) == "Z";
}

// The numbers after `key` in the log ("grandchild 1234").
std::vector<pid_t> pidsAfter(const std::string& log, const std::string& key) {
  std::vector<pid_t> out;
  const std::regex re(key + " ([0-9]+)");
  for (std::sregex_iterator it(log.begin(), log.end(), re), end; it != end; ++it) {
    out.push_back(std::stoi((*it)[1]));
  }
  return out;
}

TEST(Supervisor, APublisherKilledIsRestartedAndItsSubscribersGetItsChannelBack) {
  SupervisedHub h(std::string(R"([{"name": "ticker", "command": [")") + FLOWCTL_BIN +
                  R"(", "pub", "tick", "x", "--rate", "50", "--wait-ms", "0"],
        "account": "guest", "ready": "guest.tick", "backoff_ms": 100}])");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-READY ticker is up (channel guest.tick is there)")) << h.hub.log();

  skr::Loop loop;
  auto opts = skr::sat::SatelliteOptions::fromEnvironment("listener").value();
  opts.connection.address = skr::sat::Address::parse(h.hub.address()).value();
  skr::sat::Satellite sat(loop, opts);
  int received = 0;
  sat.data.connect(&sat, [&](uint16_t, const std::string&) { ++received; });
  sat.subscribe("guest.tick");
  sat.start();
  const auto spin = [&](const std::function<bool()>& done) {
    return eventually([&] {
      loop.runFor(20 * skr::kNsPerMs);
      return done();
    });
  };
  ASSERT_TRUE(spin([&] { return received >= 5; }));

  // Its flow and channel are its own: it logged in with the password the hub made for it.
  Variant s = h.ps("ticker");
  EXPECT_EQ(SupervisedHub::text(s, "state"), "running");
  EXPECT_NE(SupervisedHub::text(s, "flows").find(R"("user":"guest")"), std::string::npos)
      << SupervisedHub::text(s, "flows");
  EXPECT_EQ(SupervisedHub::text(s, "channels"), R"(["guest.tick"])");
  const pid_t pid = static_cast<pid_t>(std::stoi(SupervisedHub::text(s, "pid")));
  ASSERT_GT(pid, 0);
  EXPECT_NE(h.hub.log().find("supervised satellite ticker"), std::string::npos);

  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  ASSERT_TRUE(h.hub.waitLog("exited: signal 9 (SIGKILL)")) << h.hub.log();
  ASSERT_TRUE(h.hub.waitLog("SAT-RESTART ticker starts again in 100 ms")) << h.hub.log();
  ASSERT_TRUE(eventually([&] { return h.count("SAT-READY ticker") == 2; })) << h.hub.log();
  const int before = received;
  EXPECT_TRUE(spin([&] { return received >= before + 5; }))
      << "the subscriber did not get the channel back: " << received;
  s = h.ps("ticker");
  EXPECT_EQ(SupervisedHub::text(s, "restarts"), "1");
  EXPECT_EQ(SupervisedHub::text(s, "last_exit"), "signal 9 (SIGKILL)");
  EXPECT_NE(std::stoi(SupervisedHub::text(s, "pid")), pid);
}

TEST(Supervisor, ACrashLoopBacksOffAndStopsAtTheLimit) {
  SupervisedHub h(R"([{"name": "crash", "command": ["sh", "-c", "echo trying; exit 3"],
        "backoff_ms": 50, "max_backoff_ms": 300, "max_restarts_per_minute": 5}])");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-GAVE-UP crash started 5 times in the last minute")) << h.hub.log();
  const std::string log = h.hub.log();
  EXPECT_EQ(h.count("SAT-STARTED crash"), 5u);
  // The delay doubles up to its ceiling.
  std::vector<int> delays;
  const std::regex re("crash starts again in ([0-9]+) ms");
  for (std::sregex_iterator it(log.begin(), log.end(), re), end; it != end; ++it) {
    delays.push_back(std::stoi((*it)[1]));
  }
  EXPECT_EQ(delays, (std::vector<int>{50, 100, 200, 300})) << log;
  EXPECT_EQ(h.count("SAT-STDOUT trying"), 5u);
  Variant s = h.ps("crash");
  EXPECT_EQ(SupervisedHub::text(s, "state"), "failed");
  EXPECT_EQ(SupervisedHub::text(s, "last_exit"), "exit 3");
  // Not started again by itself; by the operator, it is.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(h.count("SAT-STARTED crash"), 5u);
  EXPECT_NE(h.flowctl({"start", "crash"}).find("crash"), std::string::npos);
  EXPECT_TRUE(eventually([&] { return h.count("SAT-STARTED crash") >= 6; })) << h.hub.log();
}

TEST(Supervisor, OneThatIgnoresSigtermIsKilledAfterItsGracePeriod) {
  SupervisedHub h(R"([{"name": "stubborn", "grace_ms": 600, "restart": "always",
        "command": ["sh", "-c", "trap '' TERM; echo up; while true; do sleep 0.05; done"]}])");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-STDOUT up")) << h.hub.log();
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_NE(h.flowctl({"stop", "stubborn"}).find("stubborn stopping"), std::string::npos);
  ASSERT_TRUE(h.hub.waitLog("stubborn (reaper")) << h.hub.log();
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_NE(h.hub.log().find("exited: signal 9 (SIGKILL)"), std::string::npos) << h.hub.log();
  EXPECT_GE(took, std::chrono::milliseconds(550));
  // The reaper killed it after the grace period; the hub's own last resort was not needed.
  EXPECT_EQ(h.hub.log().find("SAT-KILL"), std::string::npos) << h.hub.log();
  EXPECT_EQ(SupervisedHub::text(h.ps("stubborn"), "state"), "stopped");
  // Stopped by the operator: "always" does not bring it back.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(h.count("SAT-STARTED stubborn"), 1u);
  // Restarted by the operator, it is.
  h.flowctl({"restart", "stubborn"});
  EXPECT_TRUE(eventually([&] { return h.count("SAT-STARTED stubborn") == 2; })) << h.hub.log();
}

TEST(Supervisor, KillingTheHubWithSigkillLeavesNoDescendant) {
  // A shell that starts a grandchild, and one that leaves its session and process group.
  SupervisedHub h(R"([{"name": "family", "command": ["sh", "-c",
        "sleep 1000 & echo grandchild $!; setsid sleep 1000 & echo detached $!; echo shell $$; wait"]}])");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-STDOUT shell")) << h.hub.log();
  ASSERT_TRUE(h.hub.waitLog("SAT-STDOUT detached")) << h.hub.log();
  const std::string log = h.hub.log();
  std::vector<pid_t> pids = pidsAfter(log, "grandchild");
  for (const char* key : {"detached", "shell"}) {
    const auto more = pidsAfter(log, key);
    pids.insert(pids.end(), more.begin(), more.end());
  }
  ASSERT_EQ(pids.size(), 3u) << log;
  for (pid_t p : pids) ASSERT_FALSE(gone(p)) << p;
  h.hub.kill(SIGKILL);
  for (pid_t p : pids) EXPECT_TRUE(eventually([&] { return gone(p); }, 5000)) << "pid " << p;
  for (pid_t p : pids) ::kill(p, SIGKILL);  // a failure above leaves nothing behind
}

TEST(Supervisor, AChattyChildsOutputIsBoundedInTheHubsLog) {
  SupervisedHub h(R"([{"name": "chatty", "log_lines_per_second": 20, "restart": "never",
        "command": ["sh", "-c", "head -c 10000 /dev/zero | tr '\\000' a; echo; i=0; while [ $i -lt 3000 ]; do echo line $i; i=$((i+1)); done; sleep 30"]}])");
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-LOG-DROPPED")) << h.hub.log();
  // The long line is cut; the hub's log got at most 20 lines a second; flowctl logs the last.
  EXPECT_NE(h.hub.log().find("[... 5904 bytes cut]"), std::string::npos);
  EXPECT_TRUE(eventually([&] {
    return h.flowctl({"logs", "chatty", "--lines", "2"}) == "line 2998\nline 2999\n";
  })) << h.flowctl({"logs", "chatty", "--lines", "2"});
  const auto seconds =
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::steady_clock::now() - t0)
          .count();
  EXPECT_LE(h.count("SAT-STDOUT"), 20u * (seconds + 2)) << "more than 20 lines a second logged";
  EXPECT_GE(h.count("SAT-STDOUT"), 20u);
}

TEST(Supervisor, StartsInTheOrderOfAfterAndStopsInReverseOnSigterm) {
  // Each publishes a channel and is up once it is there; c waits for b, b for a's channel.
  const auto sat = [&](const std::string& name, const std::string& after) {
    return R"({"name": ")" + name + R"(", "after": )" + after + R"(, "account": "guest",
        "ready": "guest.)" +
           name + R"(", "command": [")" + FLOWCTL_BIN + R"(", "pub", ")" + name +
           R"(", "x", "--rate", "10", "--wait-ms", "0"]})";
  };
  SupervisedHub h("[" + sat("c", R"(["b"])") + ", " + sat("b", R"(["guest.a"])") + ", " +
                  sat("a", "[]") + "]");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-READY c")) << h.hub.log();
  EXPECT_EQ(h.hub.stop(), 0);
  const std::string log = h.hub.log();
  std::vector<size_t> at;
  for (const char* line : {"SAT-STARTED a", "SAT-READY a", "SAT-STARTED b", "SAT-READY b",
                           "SAT-STARTED c", "SAT-STOPPING c", "SAT-EXITED c", "SAT-STOPPING b",
                           "SAT-EXITED b", "SAT-STOPPING a", "SAT-EXITED a", "HUB-STOP"}) {
    at.push_back(log.find(line));
    EXPECT_NE(at.back(), std::string::npos) << line << " missing:\n" << log;
  }
  EXPECT_TRUE(std::is_sorted(at.begin(), at.end())) << log;
}

TEST(Supervisor, AnAccountThatIsNoAdministratorCannotDriveThem) {
  SupervisedHub h(R"([{"name": "idle", "command": ["sleep", "1000"]}])");
  ASSERT_TRUE(h.hub.start());
  int code = 0;
  const std::string out = h.flowctl({"stop", "idle"}, &code, "guest");
  EXPECT_EQ(code, 7) << out;
  EXPECT_NE(out.find("not an administrator"), std::string::npos) << out;
  EXPECT_EQ(SupervisedHub::text(h.ps("idle"), "state"), "running");
}

TEST(Supervisor, AMissingProgramIsReportedByNameAndTheHubGoesOn) {
  SupervisedHub h(R"([{"name": "ghost", "command": ["no-such-program-here"]},
                      {"name": "fine", "command": ["sleep", "1000"]}])");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-SPAWN ghost cannot be started: no program no-such-program-here"))
      << h.hub.log();
  EXPECT_EQ(SupervisedHub::text(h.ps("fine"), "state"), "running");
  EXPECT_EQ(SupervisedHub::text(h.ps("ghost"), "state"), "failed");
}

}  // namespace
