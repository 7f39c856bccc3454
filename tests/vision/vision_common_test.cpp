// SPDX-License-Identifier: Apache-2.0
// The helpers shared by the vision modules (plugins/vision-common): decoding. (Their JSON output
// is the module-support library's, tested in tests/support_lib.)
#include <skrobot/vision/decode.h>
#include <skrobot/vision/pipeline.h>
#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>
#include <json/value.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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

// Every raw encoding decodes to the BGR and grey images OpenCV makes from the same pixels.
TEST(DecodeFrame, EveryRawEncodingGivesTheSamePicture) {
  cv::Mat bgr(6, 8, CV_8UC3);
  cv::randu(bgr, 0, 255);
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  struct Case {
    media::Format format;
    cv::Mat pixels;    // as the encoding packs them
    double tolerance;  // lossy conversions (chroma subsampling, 16-bit) differ a little
  };
  cv::Mat rgb, rgba, bgra, deep, i420, nv12;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  grey.convertTo(deep, CV_16U, 256);
  cv::cvtColor(bgr, i420, cv::COLOR_BGR2YUV_I420);
  // nv12: the same Y plane, then U and V interleaved.
  nv12 = i420.clone();
  const int y = 6 * 8, q = y / 4;
  for (int i = 0; i < q; ++i) {
    nv12.data[y + 2 * i] = i420.data[y + i];
    nv12.data[y + 2 * i + 1] = i420.data[y + q + i];
  }
  const Case cases[] = {{media::Format::bgr8, bgr, 0},   {media::Format::rgb8, rgb, 0},
                        {media::Format::rgba8, rgba, 0}, {media::Format::bgra8, bgra, 0},
                        {media::Format::y8, grey, 0},    {media::Format::mono16, deep, 0},
                        {media::Format::i420, i420, 0},  {media::Format::nv12, nv12, 0}};
  cv::Mat from_i420;
  cv::cvtColor(i420, from_i420, cv::COLOR_YUV2BGR_I420);
  for (const auto& c : cases) {
    const auto* info = media::encodingInfo(c.format);
    SCOPED_TRACE(std::string(info->encoding));
    const std::string_view bytes(reinterpret_cast<const char*>(c.pixels.data),
                                 c.pixels.total() * c.pixels.elemSize());
    auto msg = media::makeRawFrame(c.format, 8, 6, bytes);
    ASSERT_TRUE(msg);
    auto f = media::parseFrame(*msg);
    ASSERT_TRUE(f);
    const cv::Mat out_bgr = decodeFrame(f->header, f->payload, Pixels::bgr);
    const cv::Mat out_grey = decodeFrame(f->header, f->payload, Pixels::grey);
    ASSERT_EQ(out_bgr.type(), CV_8UC3);
    ASSERT_EQ(out_grey.type(), CV_8UC1);
    ASSERT_EQ(out_bgr.size(), cv::Size(8, 6));
    ASSERT_EQ(out_grey.size(), cv::Size(8, 6));
    const bool yuv = c.format == media::Format::i420 || c.format == media::Format::nv12;
    const bool grey_only = c.format == media::Format::y8 || c.format == media::Format::mono16;
    if (yuv) {
      EXPECT_EQ(cv::norm(out_bgr, from_i420, cv::NORM_INF), 0);
      EXPECT_EQ(cv::norm(out_grey, i420.rowRange(0, 6), cv::NORM_INF), 0);
    } else if (grey_only) {
      EXPECT_EQ(cv::norm(out_grey, grey, cv::NORM_INF), 0);
    } else {
      EXPECT_EQ(cv::norm(out_bgr, bgr, cv::NORM_INF), 0);
      EXPECT_LE(cv::norm(out_grey, grey, cv::NORM_INF), 1);
    }
    // The result is a copy: the message may go away.
    EXPECT_FALSE(out_bgr.data >= reinterpret_cast<const uchar*>(msg->data()) &&
                 out_bgr.data < reinterpret_cast<const uchar*>(msg->data() + msg->size()));
  }
}

}  // namespace
}  // namespace skr::vision
