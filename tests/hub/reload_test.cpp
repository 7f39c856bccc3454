// SPDX-License-Identifier: Apache-2.0
// Reloading the hub's config while it runs (flowctl reload, SIGHUP; docs/robot.md): modules and
// satellites added, changed and removed while what did not change goes on, and a bad config that
// changes nothing.
#include "supervised_hub.h"

#include <skrobot/satellite.h>

#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

using skr::sat::test::eventually;
using skr::sat::test::SupervisedHub;

// A subscriber on a thread of its own, so that what it records is the hub's pace, not the
// test's: each payload of `channel` with its arrival time.
class Listener {
 public:
  Listener(const std::string& address, const std::string& channel)
      : thread_([this, address, channel] {
          skr::Loop loop;
          auto opts = skr::sat::SatelliteOptions::fromEnvironment("listener").value();
          opts.connection.address = skr::sat::Address::parse(address).value();
          skr::sat::Satellite sat(loop, opts);
          sat.data.connect(&sat, [this](uint16_t id, const std::string& payload) {
            std::lock_guard lock(mutex_);
            got_.push_back({skr::monotonicNs(), payload});
            ids_.insert(id);
          });
          sat.subscribe(channel);
          sat.start();
          loop.runUntil([this] { return done_.load(); }, 300 * skr::kNsPerSec);
        }) {}
  ~Listener() {
    done_ = true;
    thread_.join();
  }
  Listener(const Listener&) = delete;
  Listener& operator=(const Listener&) = delete;

  struct Message {
    skr::Nanos at;
    std::string payload;
  };
  std::vector<Message> got() {
    std::lock_guard lock(mutex_);
    return got_;
  }
  size_t count() { return got().size(); }
  // How many ids the channel had while subscribed (a channel made again gets a new one).
  size_t ids() {
    std::lock_guard lock(mutex_);
    return ids_.size();
  }
  bool has(const std::string& payload) {
    const auto all = got();
    return std::any_of(all.begin(), all.end(),
                       [&](const Message& m) { return m.payload == payload; });
  }

 private:
  std::mutex mutex_;
  std::vector<Message> got_;
  std::set<uint16_t> ids_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

std::string ticker() {
  return std::string(R"({"name": "ticker", "command": [")") + FLOWCTL_BIN +
         R"(", "pub", "tick", "x", "--rate", "50", "--wait-ms", "0"],
         "account": "guest", "ready": "guest.tick"})";
}

std::string example(const std::string& greeting) {
  return R"({"name": "example", "config": {"period_ms": 50, "greeting": ")" + greeting + R"("}})";
}

// The config's top keys for `satellites`, as HubProcess::writeConfig takes them.
std::string sats(const std::string& list) {
  return R"("satellites": )" + list + ", ";
}

TEST(Reload, ModulesComeAndGoWhileASubscriberOfASatelliteKeepsReceiving) {
  SupervisedHub h("[" + ticker() + "]");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-READY ticker")) << h.hub.log();

  Listener listener(h.hub.address(), "guest.tick");
  const auto received = [&] { return listener.count(); };
  std::string out;
  const auto reload = [&] {
    int code = -1;
    out = h.flowctl({"reload"}, &code);
    return code;
  };
  ASSERT_TRUE(eventually([&] { return received() >= 5; }));

  h.hub.writeConfig(sats("[" + ticker() + "]"), "[" + example("one") + "]");
  EXPECT_EQ(reload(), 0) << out;
  EXPECT_EQ(out, "module added: example\n");
  EXPECT_TRUE(h.hub.waitLog("EXAMPLE-START greeting 'one'")) << h.hub.log();

  h.hub.writeConfig(sats("[" + ticker() + "]"), "[" + example("two") + "]");
  EXPECT_EQ(reload(), 0) << out;
  EXPECT_EQ(out, "module reconfigured: example\n");  // in place: its config alone changed
  EXPECT_TRUE(h.hub.waitLog("EXAMPLE-RECONFIGURED greeting 'two'")) << h.hub.log();

  EXPECT_EQ(reload(), 0) << out;
  EXPECT_EQ(out, "nothing changed\n");

  h.hub.writeConfig(sats("[" + ticker() + "]"), "[]");
  EXPECT_EQ(reload(), 0) << out;
  EXPECT_EQ(out, "module removed: example\n");
  EXPECT_TRUE(h.hub.waitLog("MODULE-UNLOADED module example")) << h.hub.log();

  const size_t before = received();
  ASSERT_TRUE(eventually([&] { return received() >= before + 5; }));
  // The satellite was not touched, and its subscriber heard it all along: 50 a second, no pause.
  EXPECT_EQ(h.count("SAT-STARTED ticker"), 1u);
  const auto arrivals = listener.got();
  skr::Nanos widest = 0;
  for (size_t i = 1; i < arrivals.size(); ++i) {
    widest = std::max(widest, arrivals[i].at - arrivals[i - 1].at);
  }
  EXPECT_LT(widest, 500 * skr::kNsPerMs) << "a pause of " << widest / skr::kNsPerMs << " ms";
}

TEST(Reload, ABadConfigChangesNothingAndSaysWhere) {
  SupervisedHub h(R"([{"name": "idle", "command": ["sleep", "1000"]}])",
                  "[" + example("one") + "]");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("EXAMPLE-START")) << h.hub.log();
  // A schema problem, and a module config that breaks its declared keys: both named.
  h.hub.writeConfig(sats(R"([{"name": "idle"}])"),
                    R"([{"name": "example", "config": {"period_ms": "soon"}}])");
  int code = 0;
  std::string out = h.flowctl({"reload"}, &code);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("$.satellites[0]"), std::string::npos) << out;
  h.hub.writeConfig(sats(R"([{"name": "idle", "command": ["sleep", "1000"]}])"),
                    R"([{"name": "example", "config": {"period_ms": "soon"}}])");
  out = h.flowctl({"reload"}, &code);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("$.modules[0].config.period_ms"), std::string::npos) << out;
  EXPECT_NE(h.hub.log().find("HUB-RELOAD-REFUSED nothing changed"), std::string::npos);
  // Nothing stopped.
  EXPECT_EQ(h.count("MODULE-STOPPED"), 0u) << h.hub.log();
  EXPECT_EQ(h.count("SAT-STOPPING"), 0u) << h.hub.log();
  EXPECT_EQ(SupervisedHub::text(h.ps("idle"), "state"), "running");
  // A non-administrator may not reload.
  out = h.flowctl({"reload"}, &code, "guest");
  EXPECT_EQ(code, 7) << out;
}

TEST(Reload, SighupAddsChangesAndRemovesSatellitesAndSaysWhatTakesARestart) {
  SupervisedHub h("[" + ticker() + "]");
  ASSERT_TRUE(h.hub.start());
  ASSERT_TRUE(h.hub.waitLog("SAT-READY ticker")) << h.hub.log();

  h.hub.writeConfig(sats("[" + ticker() + R"(, {"name": "idle", "command": ["sleep", "1000"]}])"),
                    "[]");
  h.hub.signal(SIGHUP);
  ASSERT_TRUE(h.hub.waitLog("HUB-RELOAD satellite added: idle")) << h.hub.log();
  ASSERT_TRUE(h.hub.waitLog("SAT-STARTED idle")) << h.hub.log();

  // idle changed, ticker removed, and a key read only at start.
  h.hub.writeConfig(
      R"("link_hops": 4, )" + sats(R"([{"name": "idle", "command": ["sleep", "999"]}])"), "[]");
  h.hub.signal(SIGHUP);
  ASSERT_TRUE(h.hub.waitLog("HUB-RELOAD satellite removed: ticker")) << h.hub.log();
  EXPECT_TRUE(h.hub.waitLog("HUB-RELOAD satellite changed, restarted: idle")) << h.hub.log();
  EXPECT_TRUE(h.hub.waitLog("HUB-RELOAD $.link_hops changed: not applied")) << h.hub.log();
  EXPECT_TRUE(h.hub.waitLog("SAT-EXITED ticker")) << h.hub.log();
  EXPECT_TRUE(eventually([&] { return h.count("SAT-STARTED idle") == 2; })) << h.hub.log();
  EXPECT_NE(h.hub.log().find("/sleep, as idle"), std::string::npos);
  EXPECT_TRUE(eventually([&] {
    return SupervisedHub::text(h.ps("idle"), "state") == "running" &&
           SupervisedHub::text(h.ps("ticker"), "state").empty();
  })) << h.flowctl({"ps"});
  EXPECT_NE(SupervisedHub::text(h.ps("idle"), "command").find("999"), std::string::npos);
}

}  // namespace

namespace {

TEST(Reload, AModuleDroppedIntoModulePathsIsLoadedByNameByAnAdministrator) {
  skr::test::TempDir drop;
  SupervisedHub h("[]");
  h.hub.writeConfig(R"("module_paths": [")" + drop.path().string() + R"("], "satellites": [], )",
                    R"([{"name": "absent"}])");
  ASSERT_TRUE(h.hub.start());
  // Installed by a rename of a complete file, as docs/robot.md says.
  std::filesystem::copy_file(std::string(SKROBOT_MODULE_DIR) + "/example.so",
                             drop.path() / ".dropped.so.part");
  std::filesystem::rename(drop.path() / ".dropped.so.part", drop.path() / "dropped.so");
  int code = 0;
  std::string out = h.flowctl(
      {"module", "load", "dropped", "--config", R"({"period_ms": 50, "greeting": "dropped in"})"},
      &code);
  EXPECT_EQ(code, 0) << out;
  EXPECT_EQ(out, "loaded dropped (" + (drop.path() / "dropped.so").string() + ")\n");
  EXPECT_TRUE(h.hub.waitLog("EXAMPLE-START greeting 'dropped in'")) << h.hub.log();
  // hub.stats lists it with its settings, and the config's module that failed, with why.
  const auto stats =
      skr::flow::variantFromJsonText(h.flowctl({"--json", "call", "hub.inspect", "stats", "{}"}));
  ASSERT_TRUE(stats && stats->asMap() && stats->asMap()->count("modules")) << h.hub.log();
  const std::string modules = skr::flow::variantToJsonText(stats->asMap()->at("modules"));
  EXPECT_NE(modules.find(R"({"description":"Tutorial: config, log, ticks, a worker thread",)"
                         R"("file":")" +
                         (drop.path() / "dropped.so").string() +
                         R"(","name":"dropped","settings":2,"state":"started","version":"1.0.0"})"),
            std::string::npos)
      << modules;
  EXPECT_NE(modules.find(R"({"file":"","name":"absent","reason":"MODULE-NOT-FOUND: )"),
            std::string::npos)
      << modules;
  // Never a path; not twice; only what the search path has; its config checked; only by an
  // administrator.
  out = h.flowctl({"module", "load", "../dropped"}, &code);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("never by a path"), std::string::npos) << out;
  out = h.flowctl({"module", "load", "dropped"}, &code);
  EXPECT_NE(out.find("module dropped runs"), std::string::npos) << out;
  out = h.flowctl({"module", "load", "nowhere"}, &code);
  EXPECT_NE(out.find("MODULE-NOT-FOUND"), std::string::npos) << out;
  out = h.flowctl({"module", "unload", "dropped"}, &code, "guest");
  EXPECT_EQ(code, 7) << out;
  out = h.flowctl({"module", "unload", "dropped"}, &code);
  EXPECT_EQ(code, 0) << out;
  EXPECT_EQ(out, "unloaded dropped\n");
  EXPECT_TRUE(h.hub.waitLog("MODULE-UNLOADED module dropped")) << h.hub.log();
  out = h.flowctl({"module", "load", "dropped", "--config", R"({"period_ms": "soon"})"}, &code);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("MODULE-CONFIG"), std::string::npos) << out;
  EXPECT_EQ(h.count("EXAMPLE-START"), 1u) << h.hub.log();
}

}  // namespace

namespace {

TEST(Reload, AModuleReconfiguredInPlaceKeepsItsChannelsAndTheirSubscribers) {
  const auto pub = [](const std::string& name, const std::string& text) {
    return std::string(R"({"name": ")") + name + R"(", "account": "guest", "command": [")" +
           FLOWCTL_BIN + R"(", "pub", ")" + name + R"(", ")" + text +
           R"(", "--rate", "20", "--wait-ms", "0"]})";
  };
  const std::string satellites = "[" + pub("a", "from a") + ", " + pub("b", "from b") + "]";
  const auto modules = [](const std::string& input, const std::string& forward,
                          const std::string& greeting) {
    return std::string(R"([{"name": "echo", "path": ")") + SKROBOT_TEST_MODULE_DIR +
           R"(/test_channels_cpp.so", "config": {"input": ")" + input + R"(", "forward": ")" +
           forward + R"("}}, )" + example(greeting) + "]";
  };
  SupervisedHub h(satellites, modules("guest.a", "", "one"));
  ASSERT_TRUE(h.hub.start());
  Listener listener(h.hub.address(), "echo.upper");
  ASSERT_TRUE(eventually([&] { return listener.has("FROM A"); })) << h.hub.log();

  // Only the configs changed: both modules take them in place.
  h.hub.writeConfig(sats(satellites), modules("guest.b", "", "two"));
  int code = 0;
  std::string out = h.flowctl({"reload"}, &code);
  EXPECT_EQ(code, 0) << out;
  EXPECT_EQ(out, "module reconfigured: echo\nmodule reconfigured: example\n");
  EXPECT_TRUE(h.hub.waitLog("EXAMPLE-RECONFIGURED greeting 'two', period 50 ms")) << h.hub.log();
  const size_t before = listener.count();
  EXPECT_TRUE(eventually([&] {
    const auto got = listener.got();
    return std::any_of(got.begin() + static_cast<std::ptrdiff_t>(before), got.end(),
                       [](const auto& m) { return m.payload == "FROM B"; });
  })) << h.hub.log();
  EXPECT_EQ(listener.ids(), 1u) << "echo.upper was made again";
  EXPECT_EQ(h.count("MODULE-STOPPED"), 0u) << h.hub.log();
  EXPECT_EQ(h.count("MODULE-RECONFIGURED"), 2u) << h.hub.log();

  // A change it does not take in place ("forward"): restarted, and said why.
  h.hub.writeConfig(sats(satellites), modules("guest.b", "nowhere.ask", "two"));
  out = h.flowctl({"reload"}, &code);
  EXPECT_EQ(code, 0) << out;
  EXPECT_EQ(out.rfind("module changed, restarted: echo (echo did not take the change", 0), 0u)
      << out;
  EXPECT_TRUE(h.hub.waitLog("MODULE-STOPPED module echo")) << h.hub.log();
  EXPECT_TRUE(eventually([&] { return listener.ids() == 2; })) << "echo.upper not made again";
}

}  // namespace

namespace {

std::string slurp(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Reload, AModulesConfigChangedAtRunTimeIsSavedOnlyWhenAskedAndOnlyItsValue) {
  SupervisedHub h(R"([{"name": "idle", "command": ["sleep", "1000"]}])",
                  "[" + example("one") + "]");
  const std::filesystem::path file = h.dir.path() / "hub.json";
  {  // a comment of the user's, which a save must keep
    const std::string text = "// the robot of room 12\n" + slurp(file);
    std::ofstream(file, std::ios::binary | std::ios::trunc) << text;
  }
  const std::string original = slurp(file);
  ASSERT_TRUE(h.hub.start());
  int code = 0;
  std::string out = h.flowctl({"module", "config", "example"}, &code);
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find(R"(greeting           = "one")"), std::string::npos) << out;
  EXPECT_NE(out.find("integer, default 1000, >= 1, <= 3600000; the EXAMPLE-TICK period"),
            std::string::npos)
      << out;

  out = h.flowctl({"module", "config", "example", "greeting=three"}, &code);
  EXPECT_EQ(out, "example reconfigured\n");
  EXPECT_TRUE(h.hub.waitLog("EXAMPLE-RECONFIGURED greeting 'three'")) << h.hub.log();
  EXPECT_EQ(slurp(file), original) << "saved without --save";

  out = h.flowctl({"module", "config", "example", "period_ms=soon"}, &code);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("$.modules[0].config.period_ms"), std::string::npos) << out;
  EXPECT_EQ(h.count("MODULE-RECONFIGURED"), 1u) << h.hub.log();

  out = h.flowctl({"module", "config", "example", "greeting=four", "--save"}, &code);
  EXPECT_EQ(out, "example reconfigured, saved in " + file.string() + "\n");
  std::string expected = original;
  expected.replace(expected.find(R"("greeting": "one")"), 17, R"("greeting": "four")");
  EXPECT_EQ(slurp(file), expected);
  EXPECT_EQ(h.flowctl({"reload"}, &code), "nothing changed\n");
  // Only administrators.
  out = h.flowctl({"module", "config", "example", "greeting=five"}, &code, "guest");
  EXPECT_EQ(code, 7) << out;
}

}  // namespace
