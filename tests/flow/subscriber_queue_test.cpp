// SPDX-License-Identifier: Apache-2.0
// Subscriber queues sized per subscription (SUBSCRIBE_QUEUE, FlowProtocol 1.13): a subscription
// that asks for a larger queue loses nothing where the default drops, a request above
// server.subscriber_queue_max_bytes is clamped and reported (EV_ERROR limit_exceeded, the
// subscription stands) and the cap holds, a plain SUBSCRIBE keeps the default, and the grant goes
// with the subscription.
#include "flow_fixture.h"
#include "log_capture.h"

#include <skrobot/hub/flow/hub_stats.h>

#include <sys/socket.h>

#include <cstring>

namespace skr::test {
namespace {

using flow::Code;
using flow::ErrorCode;
namespace msg = flow::msg;

constexpr size_t kFrameBytes = 100 << 10;  // a large frame (a small video frame)
constexpr int kFrames = 40;                // 4 MB: four times the default queue below

class SubscriberQueue : public FlowFixture {
 protected:
  flow::ServerOptions queueOptions(size_t max_bytes, size_t default_bytes = 1 << 20) {
    auto o = defaults();
    o.subscriber_queue_bytes = default_bytes;
    o.subscriber_queue_max_bytes = max_bytes;
    return o;
  }
  // A flow; `id`: its connection's id.
  TestClient flowWithId(uint32_t& id) {
    TestClient c = connect();
    auto ok = c.loginFlow("guest", "password");
    EXPECT_TRUE(ok) << ok.error().message;
    id = ok ? ok->connection_id : 0;
    return c;
  }
  // A subscriber that does not read until the end: its socket holds little.
  TestClient slowClient(uint32_t& id) {
    TestClient c = flowWithId(id);
    int small = 4096;
    setsockopt(c.fd(), SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    return c;
  }
  // Publishes kFrames numbered frames on `id` and waits until the hub has routed them all.
  void publishAll(TestClient& owner, uint16_t id) {
    std::string p(kFrameBytes, 'v');
    for (int i = 0; i < kFrames; ++i) {
      std::memcpy(p.data(), &i, sizeof i);
      ASSERT_TRUE(owner.send(msg::Publish{id, msg::Rest{p}}));
    }
    ASSERT_TRUE(eventually([&] {
      for (const auto& c : snapshot().channels) {
        if (c.id == id) return c.messages == uint64_t(kFrames);
      }
      return false;
    }));
  }
  // What a slow subscriber got in the end: the frames' numbers, and whether it heard of drops.
  struct Received {
    std::vector<int> frames;
    uint32_t dropped = 0;
  };
  Received drain(TestClient& c) {
    Received r;
    while (auto f = c.recv(500)) {
      if (auto d = as<msg::EvData>(f)) {
        int n = -1;
        std::memcpy(&n, d->payload.bytes.data(), sizeof n);
        r.frames.push_back(n);
      } else if (auto e = as<msg::EvDropped>(f)) {
        r.dropped += e->count;
      }
    }
    return r;
  }
  flow::HubSnapshot snapshot() {
    flow::HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    return s;
  }
  uint64_t queueBytesOf(uint32_t flow_id) {
    for (const auto& f : snapshot().flows) {
      if (f.id == flow_id) return f.queue_bytes;
    }
    return 0;
  }
};

TEST_F(SubscriberQueue, ABiggerQueueLosesNothingWhereTheDefaultDrops) {
  ASSERT_TRUE(startHub(queueOptions(64 << 20)));
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "video");
  uint32_t plain_id = 0, big_id = 0;
  TestClient plain = slowClient(plain_id);
  TestClient big = slowClient(big_id);
  ASSERT_TRUE(plain.send(msg::Subscribe{1, id}));
  ASSERT_TRUE(big.send(msg::SubscribeQueue{2, id, 8 << 20}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(id) == 2; }));
  EXPECT_EQ(queueBytesOf(big_id), uint64_t(8 << 20));
  EXPECT_EQ(queueBytesOf(plain_id), uint64_t(1 << 20));
  publishAll(owner, id);

  const Received b = drain(big);
  EXPECT_EQ(b.dropped, 0u);
  ASSERT_EQ(b.frames.size(), size_t(kFrames)) << "the larger queue lost frames";
  for (int i = 0; i < kFrames; ++i) EXPECT_EQ(b.frames[i], i);

  const Received p = drain(plain);  // the default (1 MiB) drops the oldest
  EXPECT_GT(p.dropped, 0u);
  EXPECT_LT(p.frames.size(), size_t(kFrames));
  ASSERT_FALSE(p.frames.empty());
  EXPECT_EQ(p.frames.back(), kFrames - 1);  // newest wins
}

TEST_F(SubscriberQueue, ARequestAboveTheCapIsClampedReportedAndTheCapHolds) {
  LogCapture logs;
  // The queue being written is not counted against the limit, so a queue holds up to about
  // twice its size (and the socket some more): the burst is well above twice the cap.
  ASSERT_TRUE(startHub(queueOptions(1 << 20, 256 << 10)));
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "video");
  uint32_t greedy_id = 0;
  TestClient greedy = slowClient(greedy_id);
  ASSERT_TRUE(greedy.send(msg::SubscribeQueue{9, id, 1u << 30}));
  // Reported: EV_ERROR limit_exceeded with its tag and what it got; subscribed all the same.
  auto err = as<msg::EvError>(greedy.waitFor(Code::ev_error));
  ASSERT_TRUE(err);
  EXPECT_EQ(err->command, static_cast<uint8_t>(Code::subscribe_queue));
  EXPECT_EQ(err->tag, 9u);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::limit_exceeded));
  EXPECT_NE(err->message.find(std::to_string(1 << 20)), std::string::npos) << err->message;
  EXPECT_TRUE(logs.sawTag("FLOW-QUEUE-CLAMPED"));
  ASSERT_TRUE(eventually([&] { return subscribersOf(id) == 1; }));
  EXPECT_EQ(queueBytesOf(greedy_id), uint64_t(1 << 20));
  // The cap holds: 4 MB for a subscriber that does not read is dropped down to it.
  publishAll(owner, id);
  const Received g = drain(greedy);
  EXPECT_GT(g.dropped, 0u);
  EXPECT_LT(g.frames.size(), size_t(kFrames));
  ASSERT_FALSE(g.frames.empty());
  EXPECT_EQ(g.frames.back(), kFrames - 1);
}

TEST_F(SubscriberQueue, PlainSubscribeKeepsTheDefaultAndTheGrantGoesWithTheSubscription) {
  ASSERT_TRUE(startHub(queueOptions(64 << 20)));
  TestClient owner = flowClient();
  const uint16_t video = addChannel(owner, "video");
  const uint16_t other = addChannel(owner, "other", flow::ChannelKind::streaming,
                                    flow::Variant(flow::Variant::Map{}), 78);
  uint32_t c_id = 0;
  TestClient c = flowWithId(c_id);
  ASSERT_TRUE(c.send(msg::Subscribe{1, other}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(other) == 1; }));
  EXPECT_EQ(queueBytesOf(c_id), uint64_t(1 << 20));
  // A smaller request than the default does not shrink the queue; a larger one grows it.
  ASSERT_TRUE(c.send(msg::SubscribeQueue{2, video, 4096}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(video) == 1; }));
  EXPECT_EQ(queueBytesOf(c_id), uint64_t(1 << 20));
  ASSERT_TRUE(c.send(msg::SubscribeQueue{3, video, 16 << 20}));
  ASSERT_TRUE(eventually([&] { return queueBytesOf(c_id) == uint64_t(16 << 20); }));
  // Unsubscribed: back to the default. Again, then the channel removed: the same.
  ASSERT_TRUE(c.send(msg::Unsubscribe{4, video}));
  ASSERT_TRUE(eventually([&] { return queueBytesOf(c_id) == uint64_t(1 << 20); }));
  ASSERT_TRUE(c.send(msg::SubscribeQueue{5, video, 16 << 20}));
  ASSERT_TRUE(eventually([&] { return queueBytesOf(c_id) == uint64_t(16 << 20); }));
  ASSERT_TRUE(owner.send(msg::ChanRemove{6, video}));
  ASSERT_TRUE(eventually([&] { return queueBytesOf(c_id) == uint64_t(1 << 20); }));
}

TEST_F(SubscriberQueue, AnOlderClientCannotAskForAQueue) {
  ASSERT_TRUE(startHub(queueOptions(64 << 20)));
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "video");
  TestClient old = olderClient(12);
  ASSERT_EQ(old.call(msg::Empty<Code::go_async>{})->kind(), Code::reply_ok);
  ASSERT_TRUE(old.send(msg::SubscribeQueue{7, id, 8 << 20}));
  auto err = as<msg::EvError>(old.waitFor(Code::ev_error));
  ASSERT_TRUE(err);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::unsupported));
  EXPECT_EQ(subscribersOf(id), 0u);
}

}  // namespace
}  // namespace skr::test
