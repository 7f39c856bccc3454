// SPDX-License-Identifier: Apache-2.0
// Physical mode from a module (plugin ABI 1.7, docs/physical-mode.md "Modules"): the hub serves
// test_paths_camera.frames (tests/modules/paths_camera.c: numbered frames, every other one filled
// in a shared-memory slot in place) to satellites by shared memory and by a direct socket, with a
// relayed satellite beside them; each gets correct frames, in order, none twice.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "eventually.h"
#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

constexpr const char* kChannel = "test_paths_camera.frames";

class ModulePaths : public SatTest {
 protected:
  void SetUp() override {
    hub_ = std::make_unique<HubProcess>(
        SKROBOT_BIN, dir_.path(), "", "",
        std::string(R"("module_paths": [")") + SKROBOT_TEST_MODULE_DIR + R"("], )",
        R"([{"name": "test_paths_camera"}, {"name": "test_paths_camera_cpp"}])");
    ASSERT_TRUE(hub_->start()) << hub_->log();
    // The module's checks of the calls' refusals (paths_camera.c, check_calls).
    EXPECT_NE(hub_->log().find("PATHS-CHECKS ok"), std::string::npos) << hub_->log();
  }
  // A clean exit (and no sanitizer report in a sanitizer build).
  void TearDown() override {
    if (hub_) {
      EXPECT_EQ(hub_->stop(), 0) << hub_->log();
    }
  }
  std::unique_ptr<SatOnThread> subscriber(const std::string& name, uint8_t kinds,
                                          const std::string& channel = kChannel) {
    auto s = satellite(name);
    s->on([&](Satellite& sat) {
      if (kinds != 0) sat.usePaths(channel, kinds);
      sat.subscribe(channel);
    });
    return s;
  }
  // From hub.inspect "stats": the channel's messages, and those its owner published to the hub.
  struct Counters {
    int64_t channel = -1, to_hub = -1;
  };
  Counters counters() {
    Counters c;
    auto v = hubStats();
    if (!v) return c;
    for (const auto& ch : *v->find("channels")->asList()) {
      if (*ch.find("name") == flow::Variant(kChannel)) {
        c.channel = ch.find("messages")->asInt64().value_or(-1);
      }
    }
    for (const auto& f : *v->find("flows")->asList()) {
      if (*f.find("client") == flow::Variant("test_paths_camera")) {
        c.to_hub = f.find("messages_in")->asInt64().value_or(-1);
      }
    }
    return c;
  }
  static uint64_t pathMessages(SatOnThread& s) {
    return s.on([](Satellite& sat) { return sat.pathStats().path_messages; });
  }
  // The frames `s` got since its events were cleared: each must be what the module rendered,
  // in increasing order, none twice. Returns their numbers.
  static std::vector<uint64_t> checkFrames(SatOnThread& s, const std::string& channel = kChannel) {
    std::vector<uint64_t> numbers;
    for (const auto& f : s.events.with("data:" + channel + ":")) {
      const size_t space = f.find(' ', 6);
      EXPECT_EQ(f.compare(0, 6, "frame "), 0) << f.substr(0, 32);
      if (space == std::string::npos) continue;
      const uint64_t n = std::stoull(f.substr(6, space - 6));
      EXPECT_TRUE(f.substr(space + 1) == std::string(2000, char('a' + n % 26)))
          << "frame " << n << ": wrong content " << f.substr(0, 40);
      if (!numbers.empty()) {
        EXPECT_LT(numbers.back(), n) << "in order, none twice";
      }
      numbers.push_back(n);
    }
    return numbers;
  }
};

TEST_F(ModulePaths, SharedMemoryAndDirectFromAModuleBesideTheRelay) {
  auto shm = subscriber("shm", kPathShm);
  auto direct = subscriber("direct", kPathDirect);
  ASSERT_TRUE(
      eventually([&] { return pathMessages(*shm) > 0 && pathMessages(*direct) > 0; }, 20000))
      << hubLog() << shm->events.dump().substr(0, 2000);
  EXPECT_NE(hubLog().find("PHYS-GRANT " + std::string(kChannel)), std::string::npos);
  // Now a relayed one joins: the module publishes to the hub again, the others stay on paths.
  auto relayed = subscriber("relayed", 0);
  ASSERT_TRUE(eventually([&] { return relayed->events.count("data:") > 0; })) << hubLog();
  // Counts first, then the events: a message landing between the two is counted but not
  // listed, never the other way round.
  const uint64_t shm_before = pathMessages(*shm), direct_before = pathMessages(*direct);
  shm->events.clear();
  direct->events.clear();
  relayed->events.clear();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const auto by_shm = checkFrames(*shm);
  const auto by_direct = checkFrames(*direct);
  const auto by_relay = checkFrames(*relayed);
  EXPECT_GT(by_shm.size(), 10u);
  EXPECT_GT(by_direct.size(), 10u);
  EXPECT_GT(by_relay.size(), 10u);
  // Everything the path subscribers got came by their paths (not the relay).
  EXPECT_GE(pathMessages(*shm) - shm_before, by_shm.size());
  EXPECT_GE(pathMessages(*direct) - direct_before, by_direct.size());
  EXPECT_EQ(shm->on([](Satellite& s) { return s.pathStats().torn; }), 0u);
  EXPECT_EQ(shm->on([](Satellite& s) { return s.pathStats().fallbacks; }), 0u);
  EXPECT_EQ(direct->on([](Satellite& s) { return s.pathStats().fallbacks; }), 0u);
  // A direct path and the relay deliver every message, those filled in a slot too (the
  // shared-memory reader may skip to the newest).
  for (size_t k = 1; k < by_direct.size(); ++k) {
    ASSERT_EQ(by_direct[k], by_direct[k - 1] + 1) << "direct: none missing (at " << k << ")";
  }
  for (size_t k = 1; k < by_relay.size(); ++k) {
    ASSERT_EQ(by_relay[k], by_relay[k - 1] + 1) << "relayed: none missing (at " << k << ")";
  }
  // Paths only again: still delivered when nobody is relayed (the module skips the hub).
  relayed.reset();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  shm->events.clear();
  const uint64_t again = pathMessages(*shm);
  ASSERT_TRUE(eventually([&] { return pathMessages(*shm) > again + 10; })) << hubLog();
  checkFrames(*shm);
  // The hub still counts them (PHYS_COUNT, each second), though it copies none.
  const Counters a = counters();
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  const Counters b = counters();
  ASSERT_GE(a.channel, 0) << hubLog();
  ASSERT_GE(a.to_hub, 0) << hubLog();
  EXPECT_GT(b.channel, a.channel + 20) << "path messages counted on the channel";
  EXPECT_LE(b.to_hub, a.to_hub + 2) << "the module's frames no longer go through the relay";
}

TEST_F(ModulePaths, TheCppHelperFillsSlotsInPlace) {
  // test_paths_camera_cpp: the same frames through StreamChannel::offerPaths, beginPublish and
  // commitPublish (plugin_channels.hpp).
  const std::string channel = "test_paths_camera_cpp.frames";
  auto shm = subscriber("shm", kPathShm, channel);
  auto direct = subscriber("direct", kPathDirect, channel);
  ASSERT_TRUE(
      eventually([&] { return pathMessages(*shm) > 0 && pathMessages(*direct) > 0; }, 20000))
      << hubLog();
  const uint64_t before = pathMessages(*shm);  // counts first, as above
  shm->events.clear();
  direct->events.clear();
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  const auto by_shm = checkFrames(*shm, channel);
  const auto by_direct = checkFrames(*direct, channel);
  EXPECT_GT(by_shm.size(), 10u);
  EXPECT_GE(pathMessages(*shm) - before, by_shm.size());
  for (size_t k = 1; k < by_direct.size(); ++k) {
    ASSERT_EQ(by_direct[k], by_direct[k - 1] + 1) << "direct: none missing (at " << k << ")";
  }
  // Even frames were filled in a slot in place: both kinds arrive.
  EXPECT_TRUE(std::any_of(by_shm.begin(), by_shm.end(), [](uint64_t n) { return n % 2 == 0; }));
  EXPECT_TRUE(std::any_of(by_shm.begin(), by_shm.end(), [](uint64_t n) { return n % 2 == 1; }));
  // The hub stops, and its modules with it, while their paths are open: a clean exit.
  EXPECT_EQ(hub_->stop(), 0) << hub_->log();
  EXPECT_NE(hub_->log().find("SAT-PATH-CLOSED"), std::string::npos) << hub_->log();
}

}  // namespace
}  // namespace skr::sat::test
