// The helpers shared by the vision modules (plugins/vision-common): JSON output and decoding.
#include <skrobot/vision/decode.h>
#include <skrobot/vision/json_writer.h>

#include <gtest/gtest.h>
#include <json/json.h>
#include <opencv2/imgcodecs.hpp>

#include <memory>

namespace skr::vision {
namespace {

Json::Value parse(const std::string& text) {
  Json::CharReaderBuilder builder;
  std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value v;
  std::string errors;
  EXPECT_TRUE(reader->parse(text.data(), text.data() + text.size(), &v, &errors))
      << errors << " in " << text;
  return v;
}

TEST(JsonWriter, NestedValuesParseBack) {
  JsonWriter j;
  j.beginObject().key("seq").value(std::uint64_t{18446744073709551615u}).key("n").value(-3);
  j.key("list").beginArray().value(1.5).value(true).null().beginArray().value(2).endArray();
  j.endArray().key("empty").beginObject().endObject().key("nan").value(0.0 / 0.0).endObject();
  EXPECT_EQ(j.str(), R"({"seq":18446744073709551615,"n":-3,"list":[1.5,true,null,[2]],"empty":{},)"
                     R"("nan":null})");
  const Json::Value v = parse(j.str());
  EXPECT_EQ(v["list"][0].asDouble(), 1.5);
}

TEST(JsonWriter, StringsAreEscapedAndMadeValidUtf8) {
  EXPECT_EQ(jsonString("a\"b\\c\n\t\x01"), R"("a\"b\\c\n\t\u0001")");
  EXPECT_EQ(jsonString("caf\xc3\xa9"), "\"caf\xc3\xa9\"");                  // valid UTF-8 kept
  EXPECT_EQ(jsonString("bad\xff\xc3"), "\"bad\xef\xbf\xbd\xef\xbf\xbd\"");  // each bad byte
  EXPECT_EQ(jsonString("\xed\xa0\x80"), "\"\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd\"");  // surrogate
  EXPECT_EQ(parse(jsonString("x\"y")).asString(), "x\"y");
}

TEST(DecodeFrame, JpegGreyColourY8AndFailures) {
  cv::Mat bgr(20, 30, CV_8UC3, cv::Scalar(10, 200, 90));
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", bgr, jpeg);
  const std::string payload(jpeg.begin(), jpeg.end());
  media::FrameHeader h;
  h.format = media::Format::jpeg;
  cv::Mat grey = decodeFrame(h, payload, Pixels::grey);
  ASSERT_EQ(grey.type(), CV_8UC1);
  EXPECT_EQ(grey.size(), cv::Size(30, 20));
  EXPECT_EQ(decodeFrame(h, payload, Pixels::bgr).type(), CV_8UC3);
  EXPECT_TRUE(decodeFrame(h, "not a jpeg", Pixels::grey).empty());
  EXPECT_TRUE(decodeFrame(h, payload.substr(0, 10), Pixels::grey).empty());
  EXPECT_TRUE(decodeFrame(h, "", Pixels::grey).empty());

  h.format = media::Format::y8;
  h.width = 3;
  h.height = 2;
  const cv::Mat y8 = decodeFrame(h, "abcdef", Pixels::grey);
  ASSERT_EQ(y8.size(), cv::Size(3, 2));
  EXPECT_EQ(y8.at<unsigned char>(1, 2), 'f');
  EXPECT_EQ(decodeFrame(h, "abcdef", Pixels::bgr).type(), CV_8UC3);
  h.format = media::Format::pcm_s16le;
  EXPECT_TRUE(decodeFrame(h, "abcd", Pixels::grey).empty());
}

}  // namespace
}  // namespace skr::vision
