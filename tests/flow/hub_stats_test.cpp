// The hub's statistics from two snapshots (flow/hub_stats.h): rates, what began in between, what
// was re-created, queue fill.
#include <skrobot/flow/hub_stats.h>

#include <gtest/gtest.h>

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

TEST(HubStats, RatesBetweenTwoSnapshots) {
  HubSnapshot a, b;
  a.at = 10 * kNsPerSec;
  b.at = a.at + 2 * kNsPerSec;  // two seconds apart
  b.queue_limit = a.queue_limit = 1000;
  a.channels = {channel(3, "guest.camera", 100, 1000), channel(4, "guest.gone", 7),
                channel(5, "guest.again", 50)};
  ChannelCounters camera = channel(3, "guest.camera", 160, 1600);
  camera.mime = "image/jpeg";
  camera.owner_flow = 1;
  camera.subscriber_flows = {2, 9};
  camera.subscriber_paths = {"relay", "shm"};
  camera.dropped = 4;
  b.channels = {camera, channel(6, "guest.new", 10),
                channel(8, "guest.again", 6)};  // re-created: a new id
  a.flows = {flow(1, "guest", "cam", "satellite")};
  a.flows[0].messages_in = 100;
  b.flows = {flow(1, "guest", "cam", "satellite"), flow(2, "viewer", "page", "module")};
  b.flows[0].messages_in = 160;
  b.flows[0].queued_bytes = 250;
  b.flows[1].messages_out = 60;
  b.flows[1].queued_bytes = 999;

  const Variant s = statsBetween(a, b, "robot");
  EXPECT_EQ(field(s, "hub"), Variant("robot"));
  EXPECT_EQ(field(s, "interval_s"), Variant(2.0));
  ASSERT_EQ(field(s, "channels").asList()->size(), 3u);
  const Variant& cam_channel = item(s, "channels", 0);
  EXPECT_EQ(field(cam_channel, "hz"), Variant(30.0));
  EXPECT_EQ(field(cam_channel, "bytes_per_s"), Variant(300.0));
  EXPECT_EQ(field(cam_channel, "dropped_per_s"), Variant(2.0));
  EXPECT_EQ(field(cam_channel, "subscribers"), Variant(2u));
  EXPECT_EQ(field(cam_channel, "subscriber_paths"), Variant(Variant::List{"relay", "shm"}));
  EXPECT_EQ(field(cam_channel, "owner"), Variant("guest/cam"));
  EXPECT_EQ(field(cam_channel, "mime"), Variant("image/jpeg"));
  EXPECT_EQ(field(cam_channel, "kind"), Variant("streaming"));
  EXPECT_EQ(field(item(s, "channels", 1), "hz"), Variant(5.0));  // new: counted from zero
  EXPECT_EQ(field(item(s, "channels", 2), "hz"), Variant(3.0));  // re-created: from zero
  EXPECT_EQ(field(item(s, "channels", 1), "owner"), Variant(""));

  const Variant& cam = item(s, "flows", 0);
  EXPECT_EQ(field(cam, "name"), Variant("guest/cam"));
  EXPECT_EQ(field(cam, "in_hz"), Variant(30.0));
  EXPECT_EQ(field(cam, "queue_fill"), Variant(0.25));
  const Variant& page = item(s, "flows", 1);
  EXPECT_EQ(field(page, "out_hz"), Variant(30.0));
  EXPECT_EQ(field(page, "queue_fill"), Variant(0.0));  // a module has no output queue
}

TEST(HubStats, NoTimeNoRates) {
  HubSnapshot a;
  a.channels = {channel(1, "guest.x", 5)};
  const Variant s = statsBetween(a, a, "h");
  EXPECT_EQ(field(item(s, "channels", 0), "hz"), Variant(0.0));
}

}  // namespace
}  // namespace skr::flow
