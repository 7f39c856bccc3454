// SPDX-License-Identifier: Apache-2.0
// Rate-capped subscriptions (SUBSCRIBE_RATE, FlowProtocol 1.14), newest wins: a 100 Hz channel
// reaches a 10 Hz subscriber at most 10 times a second and ends on its last frame; a burst on a
// channel that then falls still ends on its newest frame; hub.stats shows the cap and what it
// skipped; SUBSCRIBE_QUEUE lifts the cap, UNSUBSCRIBE drops the frame held back.
#include "flow_fixture.h"

#include <skrobot/hub/flow/hub_stats.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>

namespace skr::test {
namespace {

using flow::Code;
using flow::ErrorCode;
namespace msg = flow::msg;

class SubscribeRate : public FlowFixture {
 protected:
  void publish(TestClient& owner, uint16_t id, int n) {
    std::string p(64, 'x');
    std::memcpy(p.data(), &n, sizeof n);
    ASSERT_TRUE(owner.send(msg::Publish{id, msg::Rest{p}}));
  }
  // The frames' numbers `c` gets within `ms` of silence.
  std::vector<int> frames(TestClient& c, int ms) {
    std::vector<int> out;
    while (auto f = c.recv(ms)) {
      if (auto d = as<msg::EvData>(f)) {
        int n = -1;
        std::memcpy(&n, d->payload.bytes.data(), sizeof n);
        out.push_back(n);
      }
    }
    return out;
  }
  // The capped subscriber's cap and skipped count as hub.stats gives them (0, 0: none).
  std::pair<uint64_t, uint64_t> capOf() {
    flow::HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    const flow::Variant v = flow::statsOf(s, "hub");
    for (const auto& c : *v.asMap()->at("channels").asList()) {
      const auto& m = *c.asMap();
      if (m.at("name").asString() != nullptr && *m.at("name").asString() == "guest.video") {
        const auto* hz = m.at("subscriber_max_hz").asList();
        const auto* skipped = m.at("subscriber_skipped").asList();
        if (hz == nullptr || skipped == nullptr || hz->size() != skipped->size()) return {0, 0};
        std::pair<uint64_t, uint64_t> capped{0, 0};  // the capped subscriber's
        for (size_t i = 0; i < hz->size(); ++i) {
          if (*(*hz)[i].asUint64() != 0) capped = {*(*hz)[i].asUint64(), *(*skipped)[i].asUint64()};
        }
        return capped;
      }
    }
    return {0, 0};
  }
};

TEST_F(SubscribeRate, A100HzChannelComesAtMostAtTheCapAndEndsOnItsLastFrame) {
  startHub();
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "video");
  TestClient sub = flowClient();
  ASSERT_TRUE(sub.send(msg::SubscribeRate{1, id, 0, 10}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(id) == 1; }));
  constexpr int kFrames = 100;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < kFrames; ++i) {
    publish(owner, id, i);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::vector<int> got = frames(sub, 600);
  std::printf("10 Hz cap: %zu of %d frames published over %.2f s\n", got.size(), kFrames, seconds);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.back(), kFrames - 1) << "the last frame was not delivered";
  // At most one per 100 ms of publishing, and the last one after it.
  EXPECT_LE(got.size(), static_cast<size_t>(seconds * 10) + 2) << got.size() << " in " << seconds;
  EXPECT_GE(got.size(), 3u);
  for (size_t i = 1; i < got.size(); ++i) EXPECT_LT(got[i - 1], got[i]);  // in order
  const auto [hz, skipped] = capOf();
  EXPECT_EQ(hz, 10u);
  EXPECT_EQ(skipped + got.size(), uint64_t(kFrames)) << "every frame went or was skipped";
}

TEST_F(SubscribeRate, AChannelThatFallsStillEndsOnItsNewestFrame) {
  startHub();
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "video");
  TestClient sub = flowClient();
  TestClient full = flowClient();
  ASSERT_TRUE(sub.send(msg::SubscribeRate{1, id, 0, 2}));
  ASSERT_TRUE(full.send(msg::Subscribe{1, id}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(id) == 2; }));
  for (int i = 0; i < 5; ++i) publish(owner, id, i);  // a burst, then nothing
  // The first at once, the newest when the 500 ms interval ends; the others skipped.
  EXPECT_EQ(frames(sub, 1500), (std::vector<int>{0, 4}));
  EXPECT_EQ(frames(full, 200), (std::vector<int>{0, 1, 2, 3, 4}));  // others are not capped
  EXPECT_EQ(capOf(), std::make_pair(uint64_t(2), uint64_t(3)));
}

TEST_F(SubscribeRate, SubscribeQueueLiftsTheCapAndUnsubscribeDropsTheFrameHeldBack) {
  startHub();
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "video");
  TestClient sub = flowClient();
  ASSERT_TRUE(sub.send(msg::SubscribeRate{1, id, 0, 1}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(id) == 1; }));
  publish(owner, id, 0);
  publish(owner, id, 1);  // held back for a second
  ASSERT_TRUE(eventually([&] { return capOf().first == 1; }));
  ASSERT_TRUE(sub.send(msg::Unsubscribe{2, id}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(id) == 0; }));
  EXPECT_EQ(frames(sub, 1500), (std::vector<int>{0}));
  // Again with a cap, then SUBSCRIBE_QUEUE: no cap, every frame of a burst.
  ASSERT_TRUE(sub.send(msg::SubscribeRate{3, id, 0, 1}));
  ASSERT_TRUE(sub.send(msg::SubscribeQueue{4, id, 0}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(id) == 1; }));
  for (int i = 10; i < 15; ++i) publish(owner, id, i);
  EXPECT_EQ(frames(sub, 300), (std::vector<int>{10, 11, 12, 13, 14}));
  EXPECT_EQ(capOf().first, 0u);
}

TEST_F(SubscribeRate, AnOlderClientCannotAskForARate) {
  startHub();
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "video");
  TestClient old = olderClient(13);
  ASSERT_EQ(old.call(msg::Empty<Code::go_async>{})->kind(), Code::reply_ok);
  ASSERT_TRUE(old.send(msg::SubscribeRate{7, id, 0, 5}));
  auto err = as<msg::EvError>(old.waitFor(Code::ev_error));
  ASSERT_TRUE(err);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::unsupported));
  EXPECT_EQ(subscribersOf(id), 0u);
}

}  // namespace
}  // namespace skr::test
