// SPDX-License-Identifier: Apache-2.0
// The C++ channel helpers of plugin_channels.hpp, through a real module (test_channels_cpp).
#include "module_fixture.h"

#include <skrobot/media_frame.hpp>

#include <fstream>
#include <iterator>

namespace skr::test {
namespace {

using flow::Code;
using flow::Variant;
namespace msg = flow::msg;

class ChannelsCpp : public ModuleFixture {
 protected:
  std::vector<std::string> start(const std::string& config) {
    return startModule("cpp", config, false,
                       std::string(SKROBOT_TEST_MODULE_DIR) + "/test_channels_cpp.so");
  }
};

TEST_F(ChannelsCpp, StreamSubscriptionServiceRequesterAndDatabase) {
  startHub();
  ASSERT_TRUE(start(R"({"input":"guest.in","forward":"guest.svc"})").empty());
  TestClient sat = flowClient();
  TestClient sync = syncClient();
  auto upper = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"cpp.upper"}));
  ASSERT_TRUE(upper);
  EXPECT_EQ(*upper->info.props.find("case"), Variant("upper"));
  ASSERT_TRUE(sat.send(msg::Subscribe{1, upper->info.id}));

  const uint16_t in = addChannel(sat, "in");
  ASSERT_TRUE(sat.waitFor(Code::ev_start_publish));
  ASSERT_TRUE(sat.send(msg::Publish{in, msg::Rest{"hello"}}));
  auto data = as<msg::EvData>(sat.waitFor(Code::ev_data));
  ASSERT_TRUE(data);
  EXPECT_EQ(data->payload.bytes, "HELLO");
  // The module changed a property of its channel through the channel's database.
  auto header = as<msg::EvChanHeader>(sat.waitFor(Code::ev_chan_header));
  ASSERT_TRUE(header);
  EXPECT_EQ(header->info.name, "cpp.upper");
  EXPECT_EQ(*header->info.props.find("last_length"), Variant(int64_t{5}));

  // A media frame is recognised, not upper-cased.
  media::FrameHeader h;
  h.format = media::Format::y8;
  h.seq = 42;
  h.width = 2;
  h.height = 2;
  ASSERT_TRUE(sat.send(msg::Publish{in, msg::Rest{media::makeFrame(h, "abcd")}}));
  ASSERT_TRUE(sat.send(msg::Publish{in, msg::Rest{"after"}}));
  data = as<msg::EvData>(sat.waitFor(Code::ev_data));
  ASSERT_TRUE(data);
  EXPECT_EQ(data->payload.bytes, "AFTER");
  ASSERT_EQ(sync.call(msg::DbSelect{"cpp"})->kind(), Code::reply_ok);
  auto seq = as<msg::ReplyValue>(sync.call(msg::VarGet{"media_seq"}));
  ASSERT_TRUE(seq);
  EXPECT_EQ(seq->value, Variant(int64_t{42}));
  auto count = as<msg::ReplyValue>(sync.call(msg::VarGet{"count"}));
  ASSERT_TRUE(count);
  EXPECT_EQ(count->value, Variant(int64_t{2}));

  // The module's service forwards to the satellite's service through a Requester.
  auto ask = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"cpp.ask"}));
  ASSERT_TRUE(ask);
  auto none = as<msg::ReplyValue>(sync.call(msg::ServiceCall{ask->info.id, 5000, "q", Variant(1)}));
  ASSERT_TRUE(none);
  EXPECT_EQ(*none->value.find("error"), Variant("no such channel"));

  const uint16_t svc =
      addChannel(sat, "svc", flow::ChannelKind::service, Variant(Variant::Map{}), 78);
  ASSERT_TRUE(sat.send(msg::ServiceRequest{9, ask->info.id, "double", Variant(int64_t{21})}));
  auto req = as<msg::EvServiceRequest>(sat.waitFor(Code::ev_service_request));
  ASSERT_TRUE(req);
  EXPECT_EQ(req->chan_id, svc);
  EXPECT_EQ(req->command, "double");
  ASSERT_TRUE(sat.send(msg::ServiceResponse{svc, req->request, Variant(int64_t{42})}));
  auto resp = as<msg::EvServiceResponse>(sat.waitFor(Code::ev_service_response));
  ASSERT_TRUE(resp);
  EXPECT_EQ(resp->tag, 9u);
  EXPECT_EQ(*resp->value.find("forwarded"), Variant(int64_t{42}));
}

TEST_F(ChannelsCpp, SyncFollowAndSyncSourceMakeAChainInLockstep) {
  startHub();
  ASSERT_TRUE(start(R"({"follow":"guest.clock"})").empty());
  TestClient sat = flowClient();
  TestClient sync = syncClient();
  auto upper = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"cpp.upper"}));
  auto tock = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"cpp.tock"}));
  ASSERT_TRUE(upper && tock);
  ASSERT_TRUE(sat.send(msg::Subscribe{1, upper->info.id}));
  TestClient last = flowClient();  // the end of the chain: follows the module's source
  // Commands on a flow have no reply: a round trip says those before it were handled (the
  // pulses come from another connection).
  const auto settle = [](TestClient& c) {
    ASSERT_TRUE(c.send(msg::DbSetCurrent{9, "guest"}));
    ASSERT_TRUE(c.waitFor(Code::ev_db_changed));
  };
  ASSERT_TRUE(last.send(msg::SyncFollow{2, tock->info.id, 1}));
  settle(last);
  const uint16_t clock = addChannel(sat, "clock", flow::ChannelKind::sync);
  for (uint64_t i = 1; i <= 3; ++i) {
    ASSERT_TRUE(sat.send(msg::SyncPulse{clock, i}));
    auto data = as<msg::EvData>(sat.waitFor(Code::ev_data));
    ASSERT_TRUE(data);
    EXPECT_EQ(data->payload.bytes, "pulse:" + std::to_string(i) + ":0");
    auto p = as<msg::EvSyncPulse>(last.waitFor(Code::ev_sync_pulse));
    ASSERT_TRUE(p);
    EXPECT_EQ(p->seq, i);
    ASSERT_TRUE(last.send(msg::SyncDone{tock->info.id, p->seq}));
    settle(last);
  }
}

TEST_F(ChannelsCpp, DatabaseBarrierOfAModule) {
  startHub();
  ASSERT_TRUE(start(R"({})").empty());
  TestClient sync = syncClient();
  auto ask = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"cpp.ask"}));
  ASSERT_TRUE(ask);
  auto answer =
      as<msg::ReplyValue>(sync.call(msg::ServiceCall{ask->info.id, 5000, "sync", Variant("v1")}));
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->value, Variant("on disk"));
  // The module's write is in its database's log on disk by then.
  std::ifstream in(dir_.path() / "data" / "db" / "cpp.log", std::ios::binary);
  const std::string log((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(log.find("synced"), std::string::npos) << "the barrier answered before the write";
}

TEST(MediaFrame, RoundTripAndRefusals) {
  media::FrameHeader a;
  a.format = media::Format::pcm_s16le;
  a.seq = 22050;
  a.capture_ns = -5;
  a.channels = 1;
  a.sample_rate = 22050;
  const std::string msg = media::makeFrame(a, std::string(8, '\0'));
  ASSERT_EQ(msg.size(), 40u);
  auto f = media::parseFrame(msg);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->header.seq, 22050u);
  EXPECT_EQ(f->header.capture_ns, -5);
  EXPECT_EQ(f->header.sample_rate, 22050u);
  EXPECT_EQ(media::sampleCount(*f), 4u);
  EXPECT_FALSE(media::parseFrame(msg.substr(0, 31)));       // short
  EXPECT_FALSE(media::parseFrame(msg.substr(0, 39)));       // half a sample
  EXPECT_FALSE(media::parseFrame("XKMF" + msg.substr(4)));  // magic
  media::FrameHeader y;
  y.format = media::Format::y8;
  y.width = 3;
  y.height = 2;
  EXPECT_TRUE(media::parseFrame(media::makeFrame(y, "abcdef")));
  EXPECT_FALSE(media::parseFrame(media::makeFrame(y, "abcde")));  // not width*height
  std::string bad = media::makeFrame(y, "abcdef");
  bad[6] = 9;  // unknown format
  EXPECT_FALSE(media::parseFrame(bad));
}

}  // namespace
}  // namespace skr::test
