// SPDX-License-Identifier: Apache-2.0
// The hub's statistics (flow/hub_stats.h): rate windows over the last second and the last ten,
// closed by the hub's one-second tick, the same for every reader; how hub.stats writes them.
#include "flow_fixture.h"
#include "rate_window.h"

#include <skrobot/hub/flow/hub_stats.h>

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace skr::flow {
namespace {

const Variant& field(const Variant& v, std::string_view key) {
  static const Variant kNull;
  const Variant* p = v.find(key);
  return p != nullptr ? *p : kNull;
}
const Variant& item(const Variant& stats, const char* list, size_t i) {
  return field(stats, list).asList()->at(i);
}
const Variant* named(const Variant& stats, const char* list, const std::string& name) {
  for (const Variant& c : *field(stats, list).asList()) {
    if (field(c, "name") == Variant(name)) return &c;
  }
  return nullptr;
}

// --- the window alone ---------------------------------------------------------------------------

TEST(RateWindow, OneAndTenSecondsOfAKnownRate) {
  RateWindow<1> w(0, {0});
  for (Nanos s = 1; s <= 12; ++s) w.sample(s * kNsPerSec, {static_cast<uint64_t>(30 * s)});
  EXPECT_EQ(w.over(1).delta[0], 30u);
  EXPECT_EQ(w.over(1).span_ns, kNsPerSec);
  EXPECT_EQ(w.over(10).delta[0], 300u);
  EXPECT_EQ(w.over(10).span_ns, 10 * kNsPerSec);
  EXPECT_EQ(w.age(), 12 * kNsPerSec);
}

// Younger than a window: measured from its creation, over its age.
TEST(RateWindow, YoungerThanTheWindowIsMeasuredOverItsAge) {
  RateWindow<1> w(500 * kNsPerMs, {0});
  EXPECT_EQ(w.over(1).span_ns, 0);  // no tick yet: no time covered
  w.sample(1 * kNsPerSec, {15});
  w.sample(2 * kNsPerSec, {45});
  EXPECT_EQ(w.over(1).delta[0], 30u);
  EXPECT_EQ(w.over(10).delta[0], 45u);
  EXPECT_EQ(w.over(10).span_ns, 1500 * kNsPerMs);
  EXPECT_EQ(w.age(), 1500 * kNsPerMs);
}

// --- the hub's windows, on a clock the test drives ----------------------------------------------

Nanos g_now = 0;
Nanos testClock() {
  return g_now;
}

class HubRates : public test::FlowFixture {
 protected:
  void SetUp() override {
    g_now = 1000 * kNsPerSec;
    auto o = defaults();
    o.stats_clock = &testClock;
    ASSERT_TRUE(startHub(o));
  }
  HubSnapshot snapshot() {
    HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    return s;
  }
  static const ChannelCounters& channel(const HubSnapshot& s, const std::string& name) {
    for (const auto& c : s.channels) {
      if (c.name == name) return c;
    }
    static const ChannelCounters kNone;
    ADD_FAILURE() << "no channel " << name;
    return kNone;
  }
};

// A channel published at 30 Hz throughout, one created 1.5 s before the last tick at 30 Hz, and
// one that published at 30 Hz only in the last two of its twelve seconds.
TEST_F(HubRates, KnownRatesOverTheLastSecondAndTheLastTen) {
  const Nanos start = g_now;
  std::unique_ptr<LocalClient> cam;
  uint16_t steady = 0, burst = 0, young = 0;
  onHub([&] {
    cam = server_->attachLocal("cam", "cam", {});
    steady = *cam->createChannel("steady", ChannelKind::streaming, "", Variant());
    burst = *cam->createChannel("burst", ChannelKind::streaming, "", Variant());
    for (Nanos s = 1; s <= 12; ++s) {
      g_now = start + (s - 1) * kNsPerSec + 500 * kNsPerMs;  // half-way through second s
      if (s == 11) young = *cam->createChannel("young", ChannelKind::streaming, "", Variant());
      for (int i = 0; i < 30; ++i) {
        ASSERT_TRUE(cam->publish(steady, "0123456789"));
        if (s >= 11) {
          ASSERT_TRUE(cam->publish(burst, "x"));
        }
        if (s == 12 || (s == 11 && i < 15)) {
          ASSERT_TRUE(cam->publish(young, "y"));
        }
      }
      g_now = start + s * kNsPerSec;
      server_->sampleRates();
    }
  });
  const HubSnapshot s = snapshot();
  EXPECT_EQ(s.interval_s, 1.0);
  EXPECT_EQ(s.interval_10s_s, 10.0);

  const ChannelCounters& st = channel(s, "cam.steady");
  EXPECT_EQ(st.last_1s.hz, 30.0);
  EXPECT_EQ(st.last_1s.bytes_per_s, 300.0);
  EXPECT_EQ(st.last_10s.hz, 30.0);
  EXPECT_EQ(st.age_s, 12.0);

  const ChannelCounters& b = channel(s, "cam.burst");
  EXPECT_EQ(b.last_1s.hz, 30.0);
  EXPECT_EQ(b.last_10s.hz, 6.0);  // 60 messages in the last ten seconds

  const ChannelCounters& y = channel(s, "cam.young");
  EXPECT_EQ(y.last_1s.hz, 30.0);
  EXPECT_EQ(y.last_10s.hz, 30.0);  // 45 messages over its 1.5 s
  EXPECT_EQ(y.age_s, 1.5);

  // The publisher's flow: 30 + 30 + 30 messages in the last second.
  bool found = false;
  for (const auto& f : s.flows) {
    if (f.client != "cam") continue;
    found = true;
    EXPECT_EQ(f.last_1s.in_hz, 90.0);
    EXPECT_EQ(f.last_10s.in_hz, 30.0 + 6.0 + 4.5);  // young's 45 and burst's 60 over 10 s
  }
  EXPECT_TRUE(found);
  onHub([&] { cam.reset(); });
}

// A channel re-created under the same name starts again: no rates until a tick has measured it.
TEST_F(HubRates, ARecreatedChannelStartsFromZero) {
  std::unique_ptr<LocalClient> cam;
  onHub([&] {
    cam = server_->attachLocal("cam", "cam", {});
    auto id = *cam->createChannel("frames", ChannelKind::streaming, "", Variant());
    for (int i = 0; i < 50; ++i) ASSERT_TRUE(cam->publish(id, "f"));
    g_now += kNsPerSec;
    server_->sampleRates();
    ASSERT_TRUE(cam->removeChannel(id));
    g_now += 100 * kNsPerMs;
    id = *cam->createChannel("frames", ChannelKind::streaming, "", Variant());
  });
  ChannelCounters c = channel(snapshot(), "cam.frames");
  EXPECT_EQ(c.messages, 0u);
  EXPECT_EQ(c.last_1s.hz, 0.0);
  EXPECT_EQ(c.age_s, 0.0);
  onHub([&] {
    const auto id = *cam->findChannel("cam.frames");
    for (int i = 0; i < 9; ++i) ASSERT_TRUE(cam->publish(id, "f"));
    g_now += 900 * kNsPerMs;
    server_->sampleRates();
  });
  c = channel(snapshot(), "cam.frames");
  EXPECT_EQ(c.last_1s.hz, 10.0);  // 9 messages over its 0.9 s
  EXPECT_EQ(c.last_10s.hz, 10.0);
  onHub([&] { cam.reset(); });
}

// --- hub.inspect, as readers see it -------------------------------------------------------------

class HubStatsService : public test::FlowFixture {};

// Two readers in a row get the same rates: asking does not reset anything. (The figures change
// only at the hub's one-second tick; a pair of answers on either side of one is asked again.)
TEST_F(HubStatsService, TwoReadersInARowSeeTheSameRates) {
  startHub();
  std::unique_ptr<HubStats> stats;
  std::unique_ptr<LocalClient> cam, reader;
  uint16_t frames = 0;
  std::vector<Variant> answers;
  onHub([&] {
    stats = std::make_unique<HubStats>(hub_->loop(), *server_);
    cam = server_->attachLocal("cam", "cam", {});
    frames = *cam->createChannel("frames", ChannelKind::streaming, "", Variant());
    LocalHandlers h;
    h.on_response = [&](uint16_t, uint32_t, Errc, const Variant& v) { answers.push_back(v); };
    reader = server_->attachLocal("reader", "reader", std::move(h));
  });
  // Publishing on each fast tick (100 Hz nominal) while the hub runs.
  TickId tick = 0;
  onHub([&] {
    tick = hub_->loop().addTickHandler(Tick::fast, [&] { (void)cam->publish(frames, "frame"); });
  });
  const auto ask = [&] {
    onHub(
        [&] { ASSERT_TRUE(reader->request(*reader->findChannel("hub.inspect"), 1, "stats", {})); });
  };
  // A number of the answer's cam.frames (-1: none).
  const auto figure = [](const Variant& answer, const char* key) {
    const Variant* c = named(answer, "channels", "cam.frames");
    return c != nullptr ? field(*c, key).asDouble().value_or(-1) : -1.0;
  };
  // Until a second of publishing has been measured.
  ASSERT_TRUE(test::eventually([&] {
    answers.clear();
    ask();
    bool measured = false;
    onHub([&] { measured = !answers.empty() && figure(answers.back(), "hz") > 0; });
    return measured;
  }));
  int pairs = 0;
  for (int attempt = 0; attempt < 5 && pairs == 0; ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a while after the last reader
    onHub([&] { answers.clear(); });
    ask();
    ask();
    ASSERT_TRUE(test::eventually([&] {
      size_t n = 0;
      onHub([&] { n = answers.size(); });
      return n == 2;
    }));
    std::vector<Variant> got;
    onHub([&] { got = answers; });
    if (field(got[0], "rates_until_ms") != field(got[1], "rates_until_ms")) continue;  // a tick
    ++pairs;
    for (const char* key : {"hz", "bytes_per_s", "hz_10s", "bytes_per_s_10s", "age_s"}) {
      EXPECT_EQ(figure(got[0], key), figure(got[1], key)) << key;
    }
    EXPECT_GT(figure(got[1], "hz"), 0.0);
    EXPECT_EQ(field(got[0], "interval_s").asDouble(), field(got[1], "interval_s").asDouble());
  }
  EXPECT_EQ(pairs, 1);
  onHub([&] {
    hub_->loop().removeTickHandler(tick);
    reader.reset();
    cam.reset();
    stats.reset();
  });
}

// The main loop's figures ride along: late wake-ups are the machine's, not the hub's.
TEST_F(HubStatsService, CarriesTheLoopsLateWakeUps) {
  startHub();
  onHub([&] {
    HubStats stats(hub_->loop(), *server_);
    const Variant v = stats.current();
    const Variant& loop = field(v, "loop");
    EXPECT_EQ(field(loop, "name"), Variant(hub_->loop().name()));
    EXPECT_TRUE(field(loop, "late_wakeups").asUint64().has_value());
    EXPECT_TRUE(field(loop, "late_skipped_ticks").asUint64().has_value());
    EXPECT_TRUE(field(loop, "skipped_ticks").asUint64().has_value());
  });
}

// --- how hub.stats writes a snapshot ------------------------------------------------------------

ChannelCounters channel(uint16_t id, std::string name, uint64_t messages, uint64_t bytes = 0) {
  ChannelCounters c;
  c.id = id;
  c.name = std::move(name);
  c.messages = messages;
  c.bytes = bytes;
  return c;
}

FlowCounters flow(uint32_t id, std::string user, std::string client, std::string kind) {
  FlowCounters f;
  f.id = id;
  f.user = std::move(user);
  f.client = std::move(client);
  f.kind = std::move(kind);
  return f;
}

TEST(HubStatsJson, ChannelsAndFlowsAsHubStatsCarriesThem) {
  HubSnapshot s;
  s.interval_s = 1.0;
  s.interval_10s_s = 10.0;
  s.rates_until_ms = 1234;
  ChannelCounters camera = channel(3, "guest.camera", 160, 1600);
  camera.mime = "image/jpeg";
  camera.owner_flow = 1;
  camera.subscriber_flows = {2, 9};
  camera.subscriber_paths = {"relay", "shm"};
  camera.dropped = 4;
  camera.last_1s = {30.0, 300.0, 2.0};
  camera.last_10s = {28.5, 285.0, 0.4};
  camera.age_s = 12.0;
  s.channels = {camera, channel(6, "guest.new", 10)};
  s.flows = {flow(1, "guest", "cam", "satellite"), flow(2, "viewer", "page", "module")};
  s.flows[0].messages_in = 160;
  s.flows[0].queued_bytes = 250;
  s.flows[0].queue_bytes = 1000;  // its queue's size: queue_fill is against it
  s.flows[0].last_1s.in_hz = 30.0;
  s.flows[0].last_10s.in_hz = 28.5;
  s.flows[1].queued_bytes = 999;

  const Variant v = statsOf(s, "robot");
  EXPECT_EQ(field(v, "hub"), Variant("robot"));
  EXPECT_EQ(field(v, "interval_s"), Variant(1.0));
  EXPECT_EQ(field(v, "interval_10s_s"), Variant(10.0));
  EXPECT_EQ(field(v, "rates_until_ms"), Variant(int64_t{1234}));
  ASSERT_EQ(field(v, "channels").asList()->size(), 2u);
  const Variant& cam = item(v, "channels", 0);
  EXPECT_EQ(field(cam, "hz"), Variant(30.0));
  EXPECT_EQ(field(cam, "bytes_per_s"), Variant(300.0));
  EXPECT_EQ(field(cam, "dropped_per_s"), Variant(2.0));
  EXPECT_EQ(field(cam, "hz_10s"), Variant(28.5));
  EXPECT_EQ(field(cam, "bytes_per_s_10s"), Variant(285.0));
  EXPECT_EQ(field(cam, "dropped_per_s_10s"), Variant(0.4));
  EXPECT_EQ(field(cam, "age_s"), Variant(12.0));
  EXPECT_EQ(field(cam, "messages"), Variant(uint64_t{160}));
  EXPECT_EQ(field(cam, "subscribers"), Variant(2u));
  EXPECT_EQ(field(cam, "subscriber_paths"), Variant(Variant::List{"relay", "shm"}));
  EXPECT_EQ(field(cam, "owner"), Variant("guest/cam"));
  EXPECT_EQ(field(cam, "mime"), Variant("image/jpeg"));
  EXPECT_EQ(field(cam, "kind"), Variant("streaming"));
  EXPECT_EQ(field(item(v, "channels", 1), "owner"), Variant(""));
  EXPECT_EQ(field(item(v, "channels", 1), "hz"), Variant(0.0));

  const Variant& cam_flow = item(v, "flows", 0);
  EXPECT_EQ(field(cam_flow, "name"), Variant("guest/cam"));
  EXPECT_EQ(field(cam_flow, "in_hz"), Variant(30.0));
  EXPECT_EQ(field(cam_flow, "in_hz_10s"), Variant(28.5));
  EXPECT_EQ(field(cam_flow, "queue_bytes"), Variant(uint64_t{1000}));
  EXPECT_EQ(field(cam_flow, "queue_fill"), Variant(0.25));
  EXPECT_EQ(field(item(v, "flows", 1), "queue_fill"), Variant(0.0));  // a module queues nothing
}

}  // namespace
}  // namespace skr::flow
