// SPDX-License-Identifier: Apache-2.0
// The media frame header and the channel vocabulary (plugin-api/include/skrobot/media_frame.hpp):
// raw frames made and parsed, sizes refused before the payload is read, derived properties.
#include <skrobot/media_frame.hpp>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <gtest/gtest.h>

#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

namespace media = skr::media;

namespace {

std::string pattern(std::size_t n) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) s[i] = static_cast<char>(i * 7 + 3);
  return s;
}

}  // namespace

TEST(MediaFrame, EveryRawEncodingRoundTripsWithItsPackedSize) {
  struct Case {
    media::Format format;
    std::size_t bytes_4x2;  // payload of a 4x2 frame
  };
  const Case cases[] = {{media::Format::y8, 8},     {media::Format::rgb8, 24},
                        {media::Format::bgr8, 24},  {media::Format::rgba8, 32},
                        {media::Format::bgra8, 32}, {media::Format::mono16, 16},
                        {media::Format::nv12, 12},  {media::Format::i420, 12}};
  for (const auto& c : cases) {
    SCOPED_TRACE(std::string(media::encodingInfo(c.format)->encoding));
    EXPECT_EQ(media::rawPayloadBytes(*media::encodingInfo(c.format), 4, 2), c.bytes_4x2);
    const std::string pixels = pattern(c.bytes_4x2);
    auto msg = media::makeRawFrame(c.format, 4, 2, pixels, 41, 1234);
    ASSERT_TRUE(msg);
    EXPECT_EQ(msg->size(), media::kHeaderBytes + c.bytes_4x2);
    EXPECT_EQ(static_cast<std::uint8_t>((*msg)[6]), static_cast<std::uint8_t>(c.format));
    auto f = media::parseFrame(*msg);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->header.format, c.format);
    EXPECT_EQ(f->header.width, 4);
    EXPECT_EQ(f->header.height, 2);
    EXPECT_EQ(f->header.seq, 41u);
    EXPECT_EQ(f->header.capture_ns, 1234);
    EXPECT_EQ(f->payload, pixels);
    // One byte more or less is refused by both sides.
    EXPECT_FALSE(media::makeRawFrame(c.format, 4, 2, pattern(c.bytes_4x2 - 1)));
    EXPECT_FALSE(media::parseFrame(msg->substr(0, msg->size() - 1)));
    EXPECT_FALSE(media::parseFrame(*msg + "x"));
  }
}

TEST(MediaFrame, HeaderBytesAreThoseDocumented) {
  auto msg = media::makeRawFrame(media::Format::bgr8, 2, 1, "abcdef", 0x0102030405060708, 9);
  ASSERT_TRUE(msg);
  const std::string expected =
      std::string("SKMF\x20\x00\x05\x00", 8) + std::string("\x08\x07\x06\x05\x04\x03\x02\x01", 8) +
      std::string("\x09\0\0\0\0\0\0\0", 8) + std::string("\x02\x00\x01\x00\0\0\0\0", 8) + "abcdef";
  EXPECT_EQ(*msg, expected);
}

TEST(MediaFrame, PlanarYuvNeedsEvenSizesAndZeroSizesAreRefused) {
  EXPECT_EQ(media::rawPayloadBytes(*media::encodingInfo(media::Format::nv12), 3, 2), 0u);
  EXPECT_EQ(media::rawPayloadBytes(*media::encodingInfo(media::Format::i420), 4, 3), 0u);
  EXPECT_FALSE(media::makeRawFrame(media::Format::nv12, 3, 2, pattern(9)));
  EXPECT_FALSE(media::makeRawFrame(media::Format::rgb8, 0, 2, ""));
  // A header claiming nv12 3x2 with the 9 bytes odd sizes would need: refused.
  media::FrameHeader h;
  h.format = media::Format::nv12;
  h.width = 3;
  h.height = 2;
  EXPECT_FALSE(media::parseFrame(media::makeFrame(h, pattern(9))));
  h.format = media::Format::rgb8;
  h.width = 0;
  EXPECT_FALSE(media::parseFrame(media::makeFrame(h, "")));
  // JPEG and PCM are not raw: makeRawFrame refuses them.
  EXPECT_FALSE(media::makeRawFrame(media::Format::jpeg, 2, 2, "1234"));
}

TEST(MediaFrame, AHugeClaimedSizeIsRefusedWithoutReadingPastTheMessage) {
  media::FrameHeader h;
  h.format = media::Format::rgba8;
  h.width = 65535;
  h.height = 65535;  // 17 GB of pixels claimed, 10 bytes sent
  EXPECT_FALSE(media::parseFrame(media::makeFrame(h, "0123456789")));
}

TEST(MediaFrame, UnknownFormatCodesAreRefused) {
  for (int code : {0, 11, 200, 255}) {
    std::string msg = *media::makeRawFrame(media::Format::y8, 1, 1, "a");
    msg[6] = static_cast<char>(code);
    EXPECT_FALSE(media::parseFrame(msg)) << code;
  }
}

TEST(MediaVocabulary, EncodingsAndCodesAreOneToOne) {
  std::set<std::string_view> names;
  std::set<int> codes;
  for (const auto& e : media::kEncodings) {
    names.insert(e.encoding);
    codes.insert(static_cast<int>(e.format));
    EXPECT_EQ(media::encodingInfo(e.encoding), &e);
    EXPECT_EQ(media::encodingInfo(e.format), &e);
  }
  EXPECT_EQ(names.size(), std::size(media::kEncodings));
  EXPECT_EQ(codes.size(), std::size(media::kEncodings));
  EXPECT_EQ(media::encodingInfo("yuvj420p"), nullptr);  // an older name is not an encoding
}

TEST(MediaVocabulary, OlderKeysAreDerivedFromTheEncoding) {
  Json::Value jpeg(Json::objectValue);
  skr::support::addMediaProperties(jpeg, *media::encodingInfo("jpeg"));
  EXPECT_EQ(skr::support::writeJson(jpeg),
            R"({"codec":"jpeg","data_type":"T_BYTEARRAY","encoding":"jpeg",)"
            R"("flow_type":"FT_VIDEO_DATA","message_encoding":"skrobot.media",)"
            R"("pixel_format":"yuvj420p"})");
  Json::Value mono(Json::objectValue);
  skr::support::addMediaProperties(mono, *media::encodingInfo("mono8"));
  EXPECT_EQ(mono["pixel_format"].asString(), "gray");
  EXPECT_EQ(mono["codec"].asString(), "raw");
  Json::Value bgr(Json::objectValue);
  skr::support::addMediaProperties(bgr, *media::encodingInfo("bgr8"));
  EXPECT_EQ(bgr["pixel_format"].asString(), "bgr24");
  Json::Value pcm(Json::objectValue);
  skr::support::addMediaProperties(pcm, *media::encodingInfo("s16le"));
  EXPECT_EQ(skr::support::writeJson(pcm),
            R"({"data_type":"T_BYTEARRAY","encoding":"s16le","flow_type":"FT_AUDIO_DATA",)"
            R"("format":"s16le","message_encoding":"skrobot.media"})");
  EXPECT_EQ(media::encodingInfo("s16le")->mime, "audio/L16");
  EXPECT_EQ(media::encodingInfo("jpeg")->mime, "image/jpeg");
}

// Typed channels (plugin-api/include/skrobot/channel_type.hpp), as PySketch's type_problem
// checks them too (satellite/python/tests/test_mediaframe.py).
TEST(ChannelType, AJsonChannelMayLeaveItsSchemaOutACdrOneMayNot) {
  namespace ct = skr::channel_type;
  EXPECT_EQ(ct::check({}), std::nullopt);
  EXPECT_EQ(ct::check({"json", "", "", ""}), std::nullopt);
  EXPECT_EQ(ct::check({"skrobot.media", "", "", ""}), std::nullopt);
  EXPECT_EQ(ct::check({"cdr", "geometry_msgs/msg/Twist", "ros2msg", "Vector3 linear\n"}),
            std::nullopt);
  const std::pair<ct::ChannelType, std::string> bad[] = {
      {{"cdr", "", "", ""}, "needs a schema"},
      {{"yaml", "", "", ""}, "unknown message_encoding"},
      {{"skrobot.media", "x", "jsonschema", "{}"}, "takes no schema"},
      {{"cdr", "geometry_msgs/msg/Twist", "jsonschema", "x"}, "does not go with"},
      {{"cdr", "geometry_msgs/msg/Twist", "ros2msg", ""}, "has no text"},
      {{"json", "", "jsonschema", "{}"}, "needs a schema_name"},
      {{"", "x", "jsonschema", "{}"}, "needs a message_encoding"},
  };
  for (const auto& [type, why] : bad) {
    const auto got = ct::check(type);
    ASSERT_TRUE(got) << type.message_encoding << " " << type.schema_encoding;
    EXPECT_NE(got->find(why), std::string::npos) << *got;
  }
}

TEST(ChannelType, PropertiesCarryTheTypeOrRefuseIt) {
  Json::Value props(Json::objectValue);
  skr::support::addTypeProperties(props, {"json", "skrobot.Faces", "jsonschema", "{}"});
  EXPECT_EQ(skr::support::writeJson(props),
            R"({"message_encoding":"json","schema":"{}","schema_encoding":"jsonschema",)"
            R"("schema_name":"skrobot.Faces"})");
  Json::Value plain(Json::objectValue);
  skr::support::addTypeProperties(plain, {"json", "", "", ""});
  EXPECT_EQ(skr::support::writeJson(plain), R"({"message_encoding":"json"})");
  EXPECT_THROW(skr::support::addTypeProperties(plain, {"cdr", "", "", ""}), std::invalid_argument);
}
