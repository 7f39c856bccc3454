// SPDX-License-Identifier: Apache-2.0
// Behaviour the docs promise about limits and channel identity, checked through the protocol: a
// client that does not read its replies is closed (FLOW-SLOW-CLIENT) while the hub goes on,
// connections beyond server.max_connections are refused, channel ids are not reused at once and a
// re-created channel has a new hash, and unknown channel kinds are refused.
#include "flow_fixture.h"
#include "log_capture.h"

#include <set>

namespace skr::test {
namespace {

using flow::ChannelKind;
using flow::Code;
using flow::ErrorCode;
using flow::Variant;
namespace msg = flow::msg;

class Promised : public FlowFixture {};

TEST_F(Promised, AClientThatDoesNotReadItsRepliesIsClosedAndOthersGoOn) {
  LogCapture logs;
  auto o = defaults();
  o.subscriber_queue_bytes = 64 << 10;
  o.max_frame_bytes = 256 << 10;  // the hard limit: 2 x 64 KiB + 256 KiB + 64 KiB
  ASSERT_TRUE(startHub(o));
  TestClient setup = syncClient();
  ASSERT_EQ(setup.call(msg::VarSet{"big", Variant(std::string(100 << 10, 'b'))})->kind(),
            Code::reply_ok);
  // 100 requests for 100 KiB each, and never a read: 10 MB of replies pile up in the hub.
  TestClient greedy = syncClient();
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(greedy.send(msg::VarGet{"big"}));
  ASSERT_TRUE(eventually([&] { return logs.sawTag("FLOW-SLOW-CLIENT"); }));
  // The hub goes on serving the others.
  auto v = as<msg::ReplyValue>(setup.call(msg::VarGet{"big"}));
  ASSERT_TRUE(v);
  EXPECT_EQ(v->value.asString()->size(), size_t(100 << 10));
}

TEST_F(Promised, ConnectionsBeyondTheLimitAreRefusedUntilOneLeaves) {
  LogCapture logs;
  auto o = defaults();
  o.max_connections = 2;
  ASSERT_TRUE(startHub(o));
  TestClient a = syncClient();
  auto b = std::make_unique<TestClient>(syncClient());
  TestClient c = connect();
  auto refused = c.login("guest", "password");
  ASSERT_FALSE(refused) << "a third connection was served";
  // Told why, in answer to its LOGIN.
  EXPECT_NE(refused.error().message.find("server.max_connections"), std::string::npos)
      << refused.error().message;
  EXPECT_TRUE(eventually([&] { return logs.sawTag("FLOW-LIMIT"); }));
  // The others stay up.
  EXPECT_EQ(a.call(msg::VarSet{"x", Variant(1)})->kind(), Code::reply_ok);
  EXPECT_EQ(b->call(msg::VarSet{"y", Variant(2)})->kind(), Code::reply_ok);
  // One leaves: a new one is accepted.
  b.reset();
  ASSERT_TRUE(eventually([&] {
    TestClient d = connect();
    return static_cast<bool>(d.login("guest", "password"));
  }));
}

TEST_F(Promised, ChannelIdsAreNotReusedAtOnceAndARecreatedChannelHasANewHash) {
  startHub();
  TestClient owner = flowClient();
  TestClient reader = syncClient();
  std::set<uint16_t> ids;
  std::set<uint64_t> hashes;
  for (int i = 0; i < 5; ++i) {
    const uint16_t id = addChannel(owner, "again", ChannelKind::streaming, Variant(Variant::Map{}),
                                   uint32_t(100 + i));
    ASSERT_NE(id, 0);
    auto info = as<msg::ChannelInfoReply>(reader.call(msg::ChanInfoByName{"guest.again"}));
    ASSERT_TRUE(info);
    EXPECT_EQ(info->info.id, id);
    ids.insert(id);
    hashes.insert(info->info.hash);
    ASSERT_TRUE(owner.send(msg::ChanRemove{uint32_t(200 + i), id}));
    auto gone = as<msg::EvChanRemoved>(owner.waitFor(Code::ev_chan_removed));
    ASSERT_TRUE(gone);
    EXPECT_EQ(gone->hash, info->info.hash);
  }
  EXPECT_EQ(ids.size(), 5u) << "an id came back at once";
  EXPECT_EQ(hashes.size(), 5u) << "a re-created channel kept its hash";
}

TEST_F(Promised, UnknownChannelKindsAreRefusedAndTheConnectionStays) {
  startHub();
  TestClient owner = flowClient();
  for (const uint8_t kind : {uint8_t(0), uint8_t(5), uint8_t(9), uint8_t(255)}) {
    msg::ChanAdd add;
    add.tag = 7;
    add.kind = kind;
    add.short_name = "odd";
    ASSERT_TRUE(owner.send(add));
    auto e = as<msg::EvError>(owner.waitFor(Code::ev_error));
    ASSERT_TRUE(e) << "kind " << int(kind);
    EXPECT_EQ(e->error, uint16_t(ErrorCode::invalid_argument)) << "kind " << int(kind);
    EXPECT_EQ(e->tag, 7u);
  }
  EXPECT_NE(addChannel(owner, "fine"), 0) << "the connection did not stay usable";
}

}  // namespace
}  // namespace skr::test
