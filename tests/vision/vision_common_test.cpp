// SPDX-License-Identifier: Apache-2.0
// The helpers shared by the vision modules (plugins/vision-common): decoding. (Their JSON output
// is the module-support library's, tested in tests/support_lib.)
#include <skrobot/vision/decode.h>
#include <skrobot/vision/pipeline.h>
#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>
#include <json/value.h>
#include <opencv2/imgcodecs.hpp>

#include <memory>

namespace skr::vision {
namespace {

TEST(ResultObject, CarriesTheFieldsOfEveryDetection) {
  FrameIn in;
  in.header.seq = 18446744073709551615u;
  in.header.capture_ns = -5;
  in.image = cv::Mat(20, 30, CV_8UC1);
  Json::Value v = resultObject(in);
  v["faces"] = Json::Value(Json::arrayValue);
  EXPECT_EQ(support::writeJson(v),
            R"({"capture_ns":-5,"faces":[],"height":20,"seq":18446744073709551615,"width":30})");
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
