// SPDX-License-Identifier: Apache-2.0
// sensor_msgs Image and CompressedImage as media frames (plugin-api/ros2/images.cpp), checked
// against the generic CDR codec of the shipped definitions (itself checked byte for byte against
// @foxglove/rosmsg2-serialization): what one writes the other reads, both ways.
#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>
#include <skrobot/ros2/images.h>
#include <skrobot/media_frame.hpp>
#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>

#include <string>

namespace ros2 = skr::ros2;
namespace media = skr::media;

namespace {

const ros2::Registry& shipped() {
  static const ros2::Registry r = [] {
    ros2::Registry out;
    EXPECT_TRUE(out.addFolder(SKROBOT_ROS2_MSGS));
    return out;
  }();
  return r;
}

std::string pixels(std::size_t n) {
  std::string out(n, '\0');
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<char>(i * 7 + 1);
  return out;
}

// A JPEG's first segments (SOI, APP0, a frame header of `sof` for width x height), as much of
// the file as jpegSize reads, then the end marker.
std::string jpegHead(std::uint8_t sof, std::uint16_t width, std::uint16_t height) {
  std::string j = "\xFF\xD8\xFF\xE0";
  j += std::string("\x00\x06JFIF", 6);
  j += "\xFF";
  j.push_back(static_cast<char>(sof));
  j += std::string("\x00\x0B\x08", 3);
  for (std::uint16_t v : {height, width}) {
    j.push_back(static_cast<char>(v >> 8));
    j.push_back(static_cast<char>(v & 0xFF));
  }
  j += std::string("\x01\x01\x11\x00\xFF\xD9", 6);
  return j;
}

Json::Value asJson(std::string_view type, const std::string& cdr) {
  auto v = ros2::cdrToJson(shipped(), type, cdr);
  EXPECT_TRUE(v) << (v ? "" : v.error().message);
  return v ? *v : Json::Value();
}

}  // namespace

TEST(Ros2Images, ARawFrameIsAnImageAndBack) {
  const std::string px = pixels(3 * 2 * 3);
  auto frame = media::makeRawFrame(media::Format::rgb8, 3, 2, px, 41, 1'700'000'000'123'456'789);
  ASSERT_TRUE(frame);
  auto cdr = ros2::frameToImage(ros2::kImageType, *frame, "camera_link", 5);
  ASSERT_TRUE(cdr) << cdr.error().message;
  const Json::Value j = asJson(ros2::kImageType, *cdr);
  EXPECT_EQ(j["header"]["stamp"]["sec"].asInt64(), 1'700'000'000);
  EXPECT_EQ(j["header"]["stamp"]["nanosec"].asInt64(), 123'456'789);
  EXPECT_EQ(j["header"]["frame_id"].asString(), "camera_link");
  EXPECT_EQ(j["height"].asInt(), 2);
  EXPECT_EQ(j["width"].asInt(), 3);
  EXPECT_EQ(j["encoding"].asString(), "rgb8");
  EXPECT_EQ(j["is_bigendian"].asInt(), 0);
  EXPECT_EQ(j["step"].asInt(), 9);
  ASSERT_EQ(j["data"].size(), px.size());
  for (Json::ArrayIndex i = 0; i < px.size(); ++i) {
    EXPECT_EQ(j["data"][i].asUInt(), static_cast<unsigned char>(px[i])) << i;
  }
  auto back = ros2::imageToFrame(ros2::kImageType, *cdr, 41, 5);
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(*back, *frame);
}

TEST(Ros2Images, EveryImageEncodingGoesBothWays) {
  for (auto f : {media::Format::rgb8, media::Format::bgr8, media::Format::rgba8,
                 media::Format::bgra8, media::Format::y8, media::Format::mono16}) {
    const auto& info = *media::encodingInfo(f);
    auto frame = media::makeRawFrame(f, 5, 3, pixels(media::rawPayloadBytes(info, 5, 3)), 1, 9);
    ASSERT_TRUE(frame);
    auto cdr = ros2::frameToImage(ros2::kImageType, *frame, "", 5);
    ASSERT_TRUE(cdr) << info.encoding << ": " << cdr.error().message;
    EXPECT_EQ(asJson(ros2::kImageType, *cdr)["encoding"].asString(), info.encoding);
    auto back = ros2::imageToFrame(ros2::kImageType, *cdr, 1, 5);
    ASSERT_TRUE(back) << info.encoding << ": " << back.error().message;
    EXPECT_EQ(*back, *frame) << info.encoding;
  }
}

TEST(Ros2Images, PaddedRowsAreRepackedAndBigEndianSwapped) {
  // 2x2 rgb8 rows of 6 bytes in a step of 8, written by the generic codec as a ROS node would.
  auto padded =
      ros2::jsonToCdr(shipped(), ros2::kImageType,
                      *skr::support::parseJson(R"({"header": {"stamp": {"sec": 0, "nanosec": 0}},
        "height": 2, "width": 2, "encoding": "rgb8", "step": 8,
        "data": [1,2,3,4,5,6,0,0, 7,8,9,10,11,12,0,0]})"));
  ASSERT_TRUE(padded);
  auto frame = ros2::imageToFrame(ros2::kImageType, *padded, 3, 77);
  ASSERT_TRUE(frame) << frame.error().message;
  auto f = media::parseFrame(*frame);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->header.format, media::Format::rgb8);
  EXPECT_EQ(f->header.capture_ns, 77);  // a zero stamp: the receive time
  EXPECT_EQ(f->header.seq, 3u);
  EXPECT_EQ(f->payload, std::string("\x01\x02\x03\x04\x05\x06\x07\x08\x09\x0a\x0b\x0c", 12));

  auto big =
      ros2::jsonToCdr(shipped(), ros2::kImageType,
                      *skr::support::parseJson(R"({"header": {"stamp": {"sec": 2, "nanosec": 5}},
        "height": 1, "width": 2, "encoding": "mono16", "is_bigendian": 1, "step": 4,
        "data": [1, 2, 3, 4]})"));
  ASSERT_TRUE(big);
  frame = ros2::imageToFrame(ros2::kImageType, *big, 0, 77);
  ASSERT_TRUE(frame) << frame.error().message;
  f = media::parseFrame(*frame);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->header.capture_ns, 2'000'000'005);
  EXPECT_EQ(f->payload, std::string("\x02\x01\x04\x03", 4));
}

TEST(Ros2Images, AJpegIsACompressedImageAndBack) {
  const std::string jpeg = jpegHead(0xC2, 640, 480);  // progressive
  ASSERT_EQ(media::jpegSize(jpeg), (std::pair<std::uint16_t, std::uint16_t>{640, 480}));
  media::FrameHeader h;
  h.format = media::Format::jpeg;
  h.seq = 12;
  h.width = 640;
  h.height = 480;
  const std::string frame = media::makeFrame(h, jpeg);  // no capture time
  auto cdr = ros2::frameToImage(ros2::kCompressedImageType, frame, "cam", 3'000'000'001);
  ASSERT_TRUE(cdr) << cdr.error().message;
  const Json::Value j = asJson(ros2::kCompressedImageType, *cdr);
  EXPECT_EQ(j["header"]["stamp"]["sec"].asInt64(), 3);  // the export's time
  EXPECT_EQ(j["header"]["stamp"]["nanosec"].asInt64(), 1);
  EXPECT_EQ(j["format"].asString(), "jpeg");
  EXPECT_EQ(j["data"].size(), jpeg.size());
  auto back = ros2::imageToFrame(ros2::kCompressedImageType, *cdr, 12, 0);
  ASSERT_TRUE(back) << back.error().message;
  h.capture_ns = 3'000'000'001;
  EXPECT_EQ(*back, media::makeFrame(h, jpeg));

  // image_transport's compressed format names the JPEG among other words.
  Json::Value v(Json::objectValue);
  v["format"] = "rgb8; jpeg compressed bgr8";
  v["data"] = Json::Value(Json::arrayValue);
  for (char c : jpeg) v["data"].append(static_cast<unsigned char>(c));
  auto transport = ros2::jsonToCdr(shipped(), ros2::kCompressedImageType, v);
  ASSERT_TRUE(transport);
  EXPECT_TRUE(ros2::imageToFrame(ros2::kCompressedImageType, *transport, 0, 1));
}

TEST(Ros2Images, WhatHasNoFrameOrNoImageIsRefusedSayingWhy) {
  auto nv12 = media::makeRawFrame(media::Format::nv12, 2, 2, pixels(6));
  ASSERT_TRUE(nv12);
  auto r = ros2::frameToImage(ros2::kImageType, *nv12, "", 1);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("nv12"), std::string::npos) << r.error().message;
  auto rgb = media::makeRawFrame(media::Format::rgb8, 1, 1, pixels(3));
  r = ros2::frameToImage(ros2::kCompressedImageType, *rgb, "", 1);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("sensor_msgs/msg/Image"), std::string::npos);
  media::FrameHeader h;
  h.width = 1;
  h.height = 1;
  r = ros2::frameToImage(ros2::kImageType, media::makeFrame(h, jpegHead(0xC0, 1, 1)), "", 1);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("CompressedImage"), std::string::npos);
  EXPECT_FALSE(ros2::frameToImage(ros2::kImageType, "not a frame", "", 1));
  EXPECT_FALSE(ros2::frameToImage("std_msgs/msg/String", *rgb, "", 1));

  auto image = [](const char* json) {
    auto v = skr::support::parseJson(json);
    EXPECT_TRUE(v) << json;
    auto cdr = ros2::jsonToCdr(shipped(), ros2::kImageType, *v);
    EXPECT_TRUE(cdr) << json;
    return cdr ? *cdr : std::string();
  };
  r = ros2::imageToFrame(ros2::kImageType,
                         image(R"({"height":1,"width":1,"encoding":"32FC1","step":4,
                                   "data":[0,0,0,0]})"),
                         0, 1);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, skr::Errc::unsupported);
  EXPECT_NE(r.error().message.find("32FC1"), std::string::npos);
  r = ros2::imageToFrame(ros2::kImageType,
                         image(R"({"height":2,"width":2,"encoding":"rgb8","step":5,
                                   "data":[0,0,0,0,0,0,0,0,0,0,0,0]})"),
                         0, 1);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("step"), std::string::npos) << r.error().message;
  r = ros2::imageToFrame(ros2::kImageType,
                         image(R"({"height":2,"width":2,"encoding":"rgb8","step":6,
                                   "data":[0,0,0,0,0,0,0]})"),
                         0, 1);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("data"), std::string::npos) << r.error().message;
  r = ros2::imageToFrame(ros2::kImageType,
                         image(R"({"height":1,"width":70000,"encoding":"mono8","step":70000})"), 0,
                         1);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("70000"), std::string::npos) << r.error().message;

  // A sample cut short names the field it stops in; a PNG is not a JPEG.
  const std::string whole = image(R"({"height":1,"width":1,"encoding":"mono8","step":1,
                                       "data":[5]})");
  r = ros2::imageToFrame(ros2::kImageType, whole.substr(0, 30), 0, 1);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, skr::Errc::parse_error);
  EXPECT_NE(r.error().message.find("encoding"), std::string::npos) << r.error().message;
  Json::Value png(Json::objectValue);
  png["format"] = "png";
  auto cdr = ros2::jsonToCdr(shipped(), ros2::kCompressedImageType, png);
  ASSERT_TRUE(cdr);
  r = ros2::imageToFrame(ros2::kCompressedImageType, *cdr, 0, 1);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, skr::Errc::unsupported);
  png["format"] = "jpeg";  // but no JPEG in it
  cdr = ros2::jsonToCdr(shipped(), ros2::kCompressedImageType, png);
  r = ros2::imageToFrame(ros2::kCompressedImageType, *cdr, 0, 1);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("data"), std::string::npos) << r.error().message;
}

TEST(Ros2Images, JpegSizeReadsOnlyWellFormedHeaders) {
  EXPECT_EQ(media::jpegSize(jpegHead(0xC0, 1920, 1080)),
            (std::pair<std::uint16_t, std::uint16_t>{1920, 1080}));
  EXPECT_FALSE(media::jpegSize(jpegHead(0xC4, 1, 1)));  // a Huffman table, not a frame header
  const std::string j = jpegHead(0xC0, 8, 8);
  for (std::size_t n = 0; n < j.size() - 2; ++n) EXPECT_FALSE(media::jpegSize(j.substr(0, n))) << n;
  EXPECT_FALSE(media::jpegSize("\xFF\xD8\xFF\xDA\x00\x02"));  // scan data before a frame header
  EXPECT_FALSE(media::jpegSize(jpegHead(0xC0, 0, 8)));
}
