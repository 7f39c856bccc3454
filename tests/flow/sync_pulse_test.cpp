// SPDX-License-Identifier: Apache-2.0
// The sync pulse through the hub (protocol 1.4): sources as channels of kind sync, targets that
// follow them every Nth pulse, pulses dropped for a target still busy with the previous one, and
// pulses that go ahead of the data queued for a target.
#include "flow_fixture.h"
#include "log_capture.h"

namespace skr::test {
namespace {

using flow::ChannelKind;
using flow::Code;
using flow::ErrorCode;
using flow::Variant;
namespace msg = flow::msg;

class SyncPulse : public FlowFixture {
 protected:
  // The next pulse a target gets (other frames are kept for later).
  static std::optional<msg::EvSyncPulse> nextPulse(TestClient& target, int timeout_ms = 5000) {
    return as<msg::EvSyncPulse>(target.waitFor(Code::ev_sync_pulse, timeout_ms));
  }
  // Commands on a flow have no reply: a round trip through the hub says those before it were
  // handled (pulses and SYNC_DONE come from different connections: their order is the test's).
  static void settle(TestClient& c) {
    ASSERT_TRUE(c.send(msg::DbSetCurrent{6, "guest"}));
    ASSERT_TRUE(c.waitFor(Code::ev_db_changed));
  }
  static void follow(TestClient& target, uint16_t source, uint32_t every = 1) {
    ASSERT_TRUE(target.send(msg::SyncFollow{5, source, every}));
    settle(target);
  }
  static void done(TestClient& target, uint16_t source, uint64_t seq) {
    ASSERT_TRUE(target.send(msg::SyncDone{source, seq}));
    settle(target);
  }
  static void pulse(TestClient& source, uint16_t id, uint64_t time) {
    ASSERT_TRUE(source.send(msg::SyncPulse{id, time}));
    settle(source);
  }
  int64_t flowCount(uint32_t connection, const char* key) {
    TestClient reader = syncClient();
    (void)reader.call(msg::DbSelect{"_flow." + std::to_string(connection)});
    auto v = as<msg::ReplyValue>(reader.call(msg::VarGet{key}));
    return v ? v->value.asInt64().value_or(-1) : -1;
  }
};

TEST_F(SyncPulse, TargetsGetEachPulseInOrderAndEveryNth) {
  startHub();
  TestClient source = flowClient();
  const uint16_t id = addChannel(source, "clock", ChannelKind::sync);
  ASSERT_NE(id, 0);
  TestClient each = flowClient();
  TestClient third = flowClient();
  follow(each, id);
  follow(third, id, 3);
  std::vector<uint64_t> got_each, got_third;
  for (uint64_t i = 1; i <= 9; ++i) {
    ASSERT_TRUE(source.send(msg::SyncPulse{id, 1000 + i}));
    auto p = nextPulse(each);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->chan_id, id);
    EXPECT_EQ(p->source_time_ns, 1000 + p->seq);
    EXPECT_EQ(p->dropped, 0u);
    got_each.push_back(p->seq);
    done(each, id, p->seq);
    if (i % 3 == 0) {
      auto q = nextPulse(third);
      ASSERT_TRUE(q);
      got_third.push_back(q->seq);
      done(third, id, q->seq);
    }
  }
  EXPECT_EQ(got_each, (std::vector<uint64_t>{1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(got_third, (std::vector<uint64_t>{3, 6, 9}));
  EXPECT_FALSE(third.waitFor(Code::ev_sync_pulse, 100)) << "a pulse between the third ones";
  // Unfollowed: no more pulses.
  ASSERT_TRUE(each.send(msg::SyncUnfollow{7, id}));
  ASSERT_TRUE(each.send(msg::DbSetCurrent{8, "guest"}));
  ASSERT_TRUE(each.waitFor(Code::ev_db_changed));
  ASSERT_TRUE(source.send(msg::SyncPulse{id, 0}));
  EXPECT_FALSE(each.waitFor(Code::ev_sync_pulse, 200));
}

TEST_F(SyncPulse, ATargetStillBusyLosesPulsesCountedAndLoggedOnce) {
  LogCapture logs;
  startHub();
  TestClient source = flowClient();
  const uint16_t id = addChannel(source, "fast", ChannelKind::sync);
  TestClient target = connect();
  auto login = target.loginFlow("guest", "password");
  ASSERT_TRUE(login);
  follow(target, id);
  ASSERT_TRUE(source.send(msg::SyncPulse{id, 1}));
  auto first = nextPulse(target);
  ASSERT_TRUE(first);
  // Its tick for pulse 1 takes four more pulses: those are dropped for it.
  for (int i = 0; i < 4; ++i) pulse(source, id, 2);
  EXPECT_FALSE(target.waitFor(Code::ev_sync_pulse, 200));
  done(target, id, first->seq);
  pulse(source, id, 3);
  auto next = nextPulse(target);
  ASSERT_TRUE(next);
  EXPECT_EQ(next->seq, 6u);
  EXPECT_EQ(next->dropped, 4u);
  // Each pulse it got carried drops: still one episode, logged once.
  pulse(source, id, 4);  // dropped: pulse 6 is not done
  done(target, id, next->seq);
  pulse(source, id, 5);  // delivered with dropped 1
  auto third = nextPulse(target);
  ASSERT_TRUE(third);
  EXPECT_EQ(third->dropped, 1u);
  size_t lagging = 0;
  for (const auto& l : logs.lines()) lagging += l.starts_with("SYNC-TARGET-LAGGING ") ? 1 : 0;
  EXPECT_EQ(lagging, 1u) << "one line for an episode of drops";
  // The counts are in its flow database (written once a second).
  EXPECT_TRUE(eventually([&] { return flowCount(login->connection_id, "sync_dropped") == 5; }));
  EXPECT_EQ(flowCount(login->connection_id, "sync_pulses"), 3);
}

// A pulse overtakes the data the hub holds for a target that is behind with a stream; only what
// is in the socket (and one slice being written) arrives before it.
TEST_F(SyncPulse, APulseGoesAheadOfQueuedData) {
  startHub();
  TestClient camera = flowClient();
  const uint16_t video = addChannel(camera, "video");
  const uint16_t clock = addChannel(camera, "clock", ChannelKind::sync);
  TestClient target = flowClient();
  ASSERT_TRUE(target.send(msg::Subscribe{1, video}));
  ASSERT_TRUE(camera.waitFor(Code::ev_start_publish));
  follow(target, clock);
  const std::string frame(64 << 10, 'v');
  constexpr int kFrames = 64;  // 4 MiB, below the subscriber queue's 8 MiB: nothing dropped
  for (int i = 0; i < kFrames; ++i) ASSERT_TRUE(camera.send(msg::Publish{video, msg::Rest{frame}}));
  // A round trip through the hub: every frame above is queued for the target by now.
  ASSERT_TRUE(camera.send(msg::DbSetCurrent{2, "guest"}));
  ASSERT_TRUE(camera.waitFor(Code::ev_db_changed));
  ASSERT_TRUE(camera.send(msg::SyncPulse{clock, 1}));
  ASSERT_TRUE(camera.send(msg::DbSetCurrent{3, "guest"}));
  ASSERT_TRUE(camera.waitFor(Code::ev_db_changed));
  int before = -1, frames = 0;
  while (frames < kFrames) {
    auto f = target.recv();
    ASSERT_TRUE(f) << "after " << frames << " frames";
    if (f->kind() == Code::ev_sync_pulse) before = frames;
    if (f->kind() == Code::ev_data) ++frames;
  }
  if (before < 0) {
    ASSERT_TRUE(target.waitFor(Code::ev_sync_pulse, 1000)) << "no pulse at all";
  }
  EXPECT_GE(before, 0) << "the pulse came after every queued frame";
  RecordProperty("frames_before_pulse", before);
  EXPECT_LT(before, kFrames / 2) << "the pulse waited behind " << before << " of " << kFrames;
}

// Frames larger than a write slice go to the socket in slices; a pulse still goes between whole
// frames, never inside one.
TEST_F(SyncPulse, APulseWaitsForTheEndOfALargeFrameWrittenInSlices) {
  startHub();
  TestClient camera = flowClient();
  const uint16_t video = addChannel(camera, "video");
  const uint16_t clock = addChannel(camera, "clock", ChannelKind::sync);
  TestClient target = flowClient();
  ASSERT_TRUE(target.send(msg::Subscribe{1, video}));
  ASSERT_TRUE(camera.waitFor(Code::ev_start_publish));
  follow(target, clock);
  constexpr int kFrames = 6;  // 6 MiB, below the subscriber queue's 8 MiB: nothing dropped
  for (int i = 0; i < kFrames; ++i) {
    const std::string frame((1 << 20) + i, static_cast<char>('a' + i));
    ASSERT_TRUE(camera.send(msg::Publish{video, msg::Rest{frame}}));
    if (i == 1) {
      ASSERT_TRUE(camera.send(msg::SyncPulse{clock, 1}));
    }
  }
  int frames = 0, pulses = 0;
  while (frames < kFrames || pulses < 1) {
    auto f = target.recv();
    ASSERT_TRUE(f) << "after " << frames << " frames";
    if (f->kind() == Code::ev_sync_pulse) ++pulses;
    if (f->kind() != Code::ev_data) continue;
    auto d = as<msg::EvData>(*f);
    ASSERT_TRUE(d);
    const std::string_view payload = d->payload.bytes;
    ASSERT_EQ(payload.size(), size_t(1 << 20) + size_t(frames));
    EXPECT_EQ(payload.find_first_not_of(static_cast<char>('a' + frames)), std::string::npos);
    ++frames;
  }
  EXPECT_EQ(pulses, 1);
}

TEST_F(SyncPulse, RulesAndOlderClients) {
  startHub();
  TestClient source = flowClient();
  const uint16_t id = addChannel(source, "clock", ChannelKind::sync);
  const uint16_t data = addChannel(source, "data");
  TestClient other = flowClient();
  const auto error = [](TestClient& c) {
    auto e = as<msg::EvError>(c.waitFor(Code::ev_error));
    return e ? e->error : uint16_t(0);
  };
  ASSERT_TRUE(other.send(msg::SyncPulse{id, 1}));  // not its source
  EXPECT_EQ(error(other), uint16_t(ErrorCode::permission_denied));
  ASSERT_TRUE(other.send(msg::SyncFollow{1, data, 1}));  // not a source
  EXPECT_EQ(error(other), uint16_t(ErrorCode::invalid_argument));
  ASSERT_TRUE(other.send(msg::Subscribe{2, id}));  // a source is followed, not subscribed to
  EXPECT_EQ(error(other), uint16_t(ErrorCode::invalid_argument));
  ASSERT_TRUE(source.send(msg::Publish{id, msg::Rest{"x"}}));  // nor published on
  EXPECT_EQ(error(source), uint16_t(ErrorCode::invalid_argument));
  // A 1.3 client neither sees sources nor makes one.
  TestClient old = olderClient(3);
  auto list = as<msg::ChannelList>(old.call(msg::Empty<Code::chan_list>{}));
  ASSERT_TRUE(list);
  ASSERT_EQ(list->channels.size(), 1u);
  EXPECT_EQ(list->channels[0].name, "guest.data");
  ASSERT_TRUE(old.call(msg::Empty<Code::go_async>{}));
  msg::ChanAdd add;
  add.tag = 9;
  add.kind = uint8_t(ChannelKind::sync);
  add.short_name = "mine";
  ASSERT_TRUE(old.send(add));
  EXPECT_EQ(error(old), uint16_t(ErrorCode::invalid_argument));
  // A follower hears that its source is gone.
  follow(other, id);
  ASSERT_TRUE(source.send(msg::ChanRemove{3, id}));
  auto gone = as<msg::EvChanRemoved>(other.waitFor(Code::ev_chan_removed));
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->chan_id, id);
}

}  // namespace
}  // namespace skr::test
