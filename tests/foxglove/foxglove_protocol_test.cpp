// SPDX-License-Identifier: Apache-2.0
// foxglove-bridge's protocol codec and conversions, without a hub.
#include "foxglove_protocol.h"
#include "foxglove_convert.h"

#include <gtest/gtest.h>

#include <skrobot/base64.hpp>
#include <skrobot/media_frame.hpp>
#include <skrobot/support/json.hpp>

namespace fg = skr::foxglove;

namespace {

Json::Value parse(const std::string& text) {
  auto v = skr::support::parseJson(text);
  EXPECT_TRUE(v.ok()) << text;
  return v.ok() ? *v : Json::Value();
}

std::string serviceCall(std::uint32_t service, std::uint32_t call, const std::string& enc,
                        const std::string& data, std::uint32_t enc_len_override = 0xffffffff) {
  std::string out(1, '\x02');
  auto u32 = [&](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i) & 0xff));
  };
  u32(service);
  u32(call);
  u32(enc_len_override != 0xffffffff ? enc_len_override : static_cast<std::uint32_t>(enc.size()));
  return out + enc + data;
}

}  // namespace

TEST(FoxgloveDecode, SubscribeAndUnsubscribe) {
  auto m = fg::decodeClientMessage(
      false,
      R"({"op":"subscribe","subscriptions":[{"id":7,"channelId":3},{"id":8,"channelId":4}]})");
  ASSERT_TRUE(m.ok()) << m.error().describe();
  const auto& s = std::get<fg::Subscribe>(*m);
  ASSERT_EQ(s.subscriptions.size(), 2u);
  EXPECT_EQ(s.subscriptions[0], std::make_pair(7u, 3u));
  auto u = fg::decodeClientMessage(false, R"({"op":"unsubscribe","subscriptionIds":[7]})");
  ASSERT_TRUE(u.ok());
  EXPECT_EQ(std::get<fg::Unsubscribe>(*u).subscription_ids, std::vector<std::uint32_t>{7});
}

TEST(FoxgloveDecode, Parameters) {
  auto g = fg::decodeClientMessage(false,
                                   R"({"op":"getParameters","parameterNames":["db/a"],"id":"q1"})");
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(std::get<fg::GetParameters>(*g).names, std::vector<std::string>{"db/a"});
  EXPECT_EQ(std::get<fg::GetParameters>(*g).id, "q1");
  auto s = fg::decodeClientMessage(
      false,
      R"({"op":"setParameters","parameters":[{"name":"db/a","value":{"x":[1,2]}},{"name":"db/b"}]})");
  ASSERT_TRUE(s.ok());
  const auto& sp = std::get<fg::SetParameters>(*s);
  ASSERT_EQ(sp.parameters.size(), 2u);
  EXPECT_EQ((*sp.parameters[0].value)["x"][1].asInt(), 2);
  EXPECT_FALSE(sp.parameters[1].value.has_value());
  EXPECT_FALSE(sp.id.has_value());
  auto u = fg::decodeClientMessage(
      false, R"({"op":"unsubscribeParameterUpdates","parameterNames":["db/a"]})");
  ASSERT_TRUE(u.ok());
  EXPECT_FALSE(std::get<fg::ParameterUpdates>(*u).subscribe);
  auto c = fg::decodeClientMessage(false, R"({"op":"subscribeConnectionGraph"})");
  ASSERT_TRUE(c.ok());
  EXPECT_TRUE(std::get<fg::ConnectionGraph>(*c).subscribe);
}

TEST(FoxgloveDecode, ServiceCallRequest) {
  auto m = fg::decodeClientMessage(true, serviceCall(5, 9, "json", R"({"command":"x"})"));
  ASSERT_TRUE(m.ok()) << m.error().describe();
  const auto& r = std::get<fg::ServiceCallRequest>(*m);
  EXPECT_EQ(r.service_id, 5u);
  EXPECT_EQ(r.call_id, 9u);
  EXPECT_EQ(r.encoding, "json");
  EXPECT_EQ(r.data, R"({"command":"x"})");
}

TEST(FoxgloveDecode, RefusesMalformedMessages) {
  const char* bad[] = {
      "not json",
      "[1,2]",
      R"({"op":1})",
      R"({"op":"subscribe"})",
      R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})",
      R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":4294967296}]})",
      R"({"op":"subscribe","subscriptions":[{"id":1.5,"channelId":1}]})",
      R"({"op":"subscribe","subscriptions":[3]})",
      R"({"op":"unsubscribe","subscriptionIds":["a"]})",
      R"({"op":"getParameters","parameterNames":[1]})",
      R"({"op":"getParameters","parameterNames":[],"id":3})",
      R"({"op":"setParameters","parameters":[{"value":1}]})",
  };
  for (const char* text : bad) {
    auto m = fg::decodeClientMessage(false, text);
    EXPECT_FALSE(m.ok()) << text;
  }
  // Binary: empty, unknown opcode, short, an encoding length past the end or over the limit.
  EXPECT_FALSE(fg::decodeClientMessage(true, "").ok());
  EXPECT_FALSE(fg::decodeClientMessage(true, std::string(1, '\x09')).ok());
  EXPECT_FALSE(fg::decodeClientMessage(true, std::string("\x02\x01\x00", 3)).ok());
  auto past = fg::decodeClientMessage(true, serviceCall(1, 1, "json", "", 5));
  ASSERT_FALSE(past.ok());
  EXPECT_EQ(past.error().code, skr::Errc::protocol_error);
  auto huge = fg::decodeClientMessage(true, serviceCall(1, 1, "json", "", 0xfffffff0u));
  ASSERT_FALSE(huge.ok());
  EXPECT_EQ(huge.error().code, skr::Errc::limit_exceeded);
}

TEST(FoxgloveDecode, LimitsComeBeforeParsing) {
  fg::DecodeLimits lim;
  lim.max_json_bytes = 64;
  lim.max_items = 2;
  auto big = fg::decodeClientMessage(false, std::string(100, ' ') + "{}", lim);
  ASSERT_FALSE(big.ok());
  EXPECT_EQ(big.error().code, skr::Errc::limit_exceeded);
  auto many =
      fg::decodeClientMessage(false, R"({"op":"unsubscribe","subscriptionIds":[1,2,3]})", lim);
  ASSERT_FALSE(many.ok());
  EXPECT_EQ(many.error().code, skr::Errc::limit_exceeded);
  std::string deep = R"({"op":"setParameters","parameters":[{"name":"a","value":)";
  deep += std::string(40, '[') + std::string(40, ']') + "}]}";
  EXPECT_FALSE(fg::decodeClientMessage(false, deep).ok());
}

TEST(FoxgloveDecode, UnsupportedButWellFormed) {
  auto a = fg::decodeClientMessage(false, R"({"op":"advertise","channels":[]})");
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(std::get<fg::Unsupported>(*a).op, "advertise");
  auto d = fg::decodeClientMessage(true, std::string("\x01\x00\x00\x00\x00", 5));
  ASSERT_TRUE(d.ok());
  EXPECT_TRUE(std::holds_alternative<fg::Unsupported>(*d));
}

TEST(FoxgloveEncode, MessageDataLayout) {
  const std::string m = fg::messageData(0x01020304, 0x1122334455667788ull, "{}");
  ASSERT_EQ(m.size(), 15u);
  EXPECT_EQ(m[0], 1);
  EXPECT_EQ(m.substr(1, 4), std::string("\x04\x03\x02\x01", 4));
  EXPECT_EQ(m.substr(5, 8), std::string("\x88\x77\x66\x55\x44\x33\x22\x11", 8));
  EXPECT_EQ(m.substr(13), "{}");
  const std::string r = fg::serviceCallResponse(2, 3, "json", "{}");
  EXPECT_EQ(r, std::string("\x03\x02\0\0\0\x03\0\0\0\x04\0\0\0json{}", 19));
}

TEST(FoxgloveEncode, JsonMessages) {
  auto info = parse(fg::serverInfo("hub", {"services"}, {{"a", "b"}}, "s1"));
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["capabilities"][0], "services");
  EXPECT_EQ(info["metadata"]["a"], "b");
  auto adv = parse(fg::advertise({{4, "x.y", "json", "application/json", "{}", "jsonschema"}}));
  EXPECT_EQ(adv["channels"][0]["id"], 4);
  EXPECT_EQ(adv["channels"][0]["topic"], "x.y");
  EXPECT_EQ(adv["channels"][0]["schemaEncoding"], "jsonschema");
  EXPECT_EQ(parse(fg::unadvertise({4, 5}))["channelIds"][1], 5);
  auto svc = parse(fg::advertiseServices({{9, "a.b", "t", "{}", "{}"}}));
  EXPECT_EQ(svc["services"][0]["request"]["encoding"], "json");
  auto pv = parse(fg::parameterValues({{"db/a", Json::Value(3)}, {"db/b", Json::Value()}}, "q"));
  EXPECT_EQ(pv["parameters"][0]["value"], 3);
  EXPECT_FALSE(pv["parameters"][1].isMember("value"));
  EXPECT_EQ(pv["id"], "q");
  auto st = parse(fg::status(fg::StatusLevel::warning, "no"));
  EXPECT_EQ(st["level"], 1);
}

TEST(FoxgloveEncode, ConnectionGraphDiff) {
  fg::Graph a;
  a.published["x.cam"] = {"x"};
  a.subscribed["x.cam"] = {"y"};
  a.services["x.svc"] = {"x"};
  auto full = parse(fg::connectionGraphUpdate(a, nullptr));
  EXPECT_EQ(full["publishedTopics"][0]["name"], "x.cam");
  EXPECT_EQ(full["subscribedTopics"][0]["subscriberIds"][0], "y");
  EXPECT_EQ(full["advertisedServices"][0]["providerIds"][0], "x");
  fg::Graph b = a;
  b.subscribed["x.cam"] = {"y", "z"};
  b.services.clear();
  auto diff = parse(fg::connectionGraphUpdate(b, &a));
  EXPECT_EQ(diff["publishedTopics"].size(), 0u);
  EXPECT_EQ(diff["subscribedTopics"][0]["subscriberIds"].size(), 2u);
  EXPECT_EQ(diff["removedServices"][0], "x.svc");
  fg::Graph c;
  auto gone = parse(fg::connectionGraphUpdate(c, &a));
  EXPECT_EQ(gone["removedTopics"][0], "x.cam");
}

TEST(FoxgloveConvert, CompressedImage) {
  skr::media::FrameHeader h;
  h.format = skr::media::Format::jpeg;
  h.capture_ns = 1700000000123456789;
  h.width = 2;
  h.height = 2;
  auto out = fg::compressedImage(skr::media::makeFrame(h, "foo"), "cam");
  ASSERT_TRUE(out);
  auto v = parse(out->json);
  EXPECT_EQ(v["data"], "Zm9v");
  EXPECT_EQ(v["format"], "jpeg");
  EXPECT_EQ(v["frame_id"], "cam");
  EXPECT_EQ(v["timestamp"]["sec"].asUInt64(), 1700000000u);
  EXPECT_EQ(v["timestamp"]["nsec"].asUInt64(), 123456789u);
  EXPECT_EQ(out->time_ns, 1700000000123456789u);
  EXPECT_FALSE(fg::compressedImage("not a frame", "cam"));
  h.format = skr::media::Format::pcm_s16le;
  h.channels = 1;
  EXPECT_FALSE(fg::compressedImage(skr::media::makeFrame(h, "abcd"), "cam"));
}

TEST(FoxgloveConvert, RawImageInFoxglovesEncodings) {
  // bgr8 2x1: step = width * 3.
  auto out = fg::rawImage(
      *skr::media::makeRawFrame(skr::media::Format::bgr8, 2, 1, "foobar", 0, 1700000000123456789),
      "cam");
  ASSERT_TRUE(out);
  auto v = parse(out->json);
  EXPECT_EQ(v["data"], "Zm9vYmFy");
  EXPECT_EQ(v["encoding"], "bgr8");
  EXPECT_EQ(v["width"], 2);
  EXPECT_EQ(v["height"], 1);
  EXPECT_EQ(v["step"], 6);
  EXPECT_EQ(v["frame_id"], "cam");
  EXPECT_EQ(v["timestamp"]["sec"].asUInt64(), 1700000000u);
  EXPECT_EQ(v["timestamp"]["nsec"].asUInt64(), 123456789u);
  EXPECT_EQ(out->time_ns, 1700000000123456789u);
  // mono16: two bytes a pixel; nv12: step is the luma row.
  v = parse(
      fg::rawImage(*skr::media::makeRawFrame(skr::media::Format::mono16, 2, 1, "abcd"), "c")->json);
  EXPECT_EQ(v["encoding"], "mono16");
  EXPECT_EQ(v["step"], 4);
  // i420 becomes nv12: Y plane, then U and V interleaved.
  v = parse(
      fg::rawImage(*skr::media::makeRawFrame(skr::media::Format::i420, 2, 2, "YYYYUV"), "c")->json);
  EXPECT_EQ(v["encoding"], "nv12");
  EXPECT_EQ(v["step"], 2);
  EXPECT_EQ(v["data"], skr::base64::encode("YYYYUV"));
  v = parse(
      fg::rawImage(*skr::media::makeRawFrame(skr::media::Format::i420, 4, 2, "YYYYYYYYuuvv"), "c")
          ->json);
  EXPECT_EQ(v["data"], skr::base64::encode("YYYYYYYYuvuv"));
  // JPEG, audio and broken frames are not raw images.
  skr::media::FrameHeader h;
  h.format = skr::media::Format::jpeg;
  EXPECT_FALSE(fg::rawImage(skr::media::makeFrame(h, "foo"), "cam"));
  EXPECT_FALSE(fg::rawImage("not a frame", "cam"));
  EXPECT_TRUE(fg::isRawImageEncoding("rgba8"));
  EXPECT_TRUE(fg::isRawImageEncoding("i420"));
  EXPECT_FALSE(fg::isRawImageEncoding("jpeg"));
  EXPECT_FALSE(fg::isRawImageEncoding("s16le"));
  EXPECT_EQ(fg::schemaName(fg::Shape::raw_image, ""), "foxglove.RawImage");
  EXPECT_EQ(parse(fg::schemaText(fg::Shape::raw_image))["required"].size(), 7u);
}

// flowctl play makes the recorded frame again from the image message, byte for byte.
TEST(FoxgloveConvert, ImageMessagesGiveTheirFramesBack) {
  for (const auto& e : skr::media::kEncodings) {
    if (!e.video) continue;
    std::string pixels(
        e.format == skr::media::Format::jpeg ? 50 : skr::media::rawPayloadBytes(e, 4, 2), '\0');
    for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<char>(i * 37 + 11);
    skr::media::FrameHeader h;
    h.format = e.format;
    h.seq = 0xfedcba9876543210u;
    h.capture_ns = 1700000000123456789;
    h.width = 4;
    h.height = 2;
    const std::string frame = skr::media::makeFrame(h, pixels);
    auto image = e.format == skr::media::Format::jpeg ? fg::compressedImage(frame, "cam")
                                                      : fg::rawImage(frame, "cam");
    ASSERT_TRUE(image) << e.encoding;
    EXPECT_EQ(parse(image->json)["seq"].asUInt64(), h.seq) << e.encoding;
    auto back = fg::mediaFrameOf(image->json);
    ASSERT_TRUE(back) << e.encoding << ": " << back.error().message;
    EXPECT_EQ(*back, frame) << e.encoding;
  }
  // What is not such a message is refused with the reason.
  const std::string good =
      fg::rawImage(*skr::media::makeRawFrame(skr::media::Format::bgr8, 2, 1, "foobar"), "c")->json;
  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  for (const auto& bad :
       {std::string("{}"), std::string("not json"), replace("\"seq\":0", "\"seq\":-1"),
        replace("\"encoding\":\"bgr8\"", "\"encoding\":\"jpeg\""),
        replace("\"width\":2", "\"width\":3"), replace("Zm9vYmFy", "Zm9vYmF*"),
        replace("Zm9vYmFy", "Zm9vYmE=")}) {
    auto r = fg::mediaFrameOf(bad);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().code, skr::Errc::parse_error) << bad;
  }
  // Written otherwise (an escape in the base64, a nested "data" first), the same frame.
  const std::string frame = *skr::media::makeRawFrame(skr::media::Format::bgr8, 2, 1, "foobar");
  for (const auto& other :
       {replace("Zm9vYmFy", "Zm9v\\u0059mFy"), "{\"x\":{\"data\":\"QUJD\"}," + good.substr(1)}) {
    auto r = fg::mediaFrameOf(other);
    ASSERT_TRUE(r) << other << ": " << r.error().message;
    EXPECT_EQ(*r, frame) << other;
  }
}

TEST(FoxgloveConvert, Annotations) {
  auto faces = fg::imageAnnotations(
      R"({"capture_ns":5,"width":640,"height":360,"faces":[{"x":10,"y":20,"w":30,"h":40,"score":0.5}]})");
  ASSERT_TRUE(faces);
  auto v = parse(faces->json);
  ASSERT_EQ(v["points"].size(), 1u);
  EXPECT_EQ(v["points"][0]["type"], 2);
  EXPECT_EQ(v["points"][0]["points"][2]["x"].asDouble(), 40.0);
  EXPECT_EQ(v["points"][0]["points"][2]["y"].asDouble(), 60.0);
  EXPECT_EQ(v["texts"][0]["text"], "0.50");
  EXPECT_EQ(v["points"][0]["timestamp"]["nsec"], 5);
  auto motion = fg::imageAnnotations(
      R"({"capture_ns":5,"amount":0.1,"center":{"x":1,"y":2},"regions":[{"x":1,"y":1,"w":2,"h":2}]})");
  ASSERT_TRUE(motion);
  auto m = parse(motion->json);
  EXPECT_EQ(m["circles"].size(), 1u);
  EXPECT_EQ(m["points"].size(), 1u);
  EXPECT_FALSE(fg::imageAnnotations(R"({"nothing":1})"));
}

TEST(FoxgloveConvert, Joints) {
  auto j = fg::jointPositions(R"({"angles":[0.5,-1]})", {"HeadYaw", "HeadPitch"});
  ASSERT_TRUE(j);
  auto v = parse(j->json);
  EXPECT_EQ(v["positions"]["HeadYaw"].asDouble(), 0.5);
  EXPECT_EQ(v["positions"]["HeadPitch"].asDouble(), -1.0);
  EXPECT_EQ(v["angles"].size(), 2u);
}

TEST(FoxgloveConvert, SchemasAreJson) {
  for (auto shape :
       {fg::Shape::json, fg::Shape::image, fg::Shape::annotations, fg::Shape::joints}) {
    auto v = parse(fg::schemaText(shape));
    EXPECT_EQ(v["type"], "object");
  }
  EXPECT_EQ(fg::schemaName(fg::Shape::image, "image/jpeg"), "foxglove.CompressedImage");
  EXPECT_EQ(fg::schemaName(fg::Shape::json, "application/json"), "application/json");
}
