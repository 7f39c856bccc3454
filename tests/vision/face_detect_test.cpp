// SPDX-License-Identifier: Apache-2.0
// face-detect on real pictures (astronaut.png, messi5.jpg) sent by a satellite on guest.camera.
#include "vision_fixture.h"

#include <opencv2/imgproc.hpp>

#include <fstream>

namespace skr::test {
namespace {

std::vector<cv::Rect> boxes(const Json::Value& result) {
  std::vector<cv::Rect> out;
  for (const auto& f : result["faces"]) {
    out.emplace_back(f["x"].asInt(), f["y"].asInt(), f["w"].asInt(), f["h"].asInt());
  }
  return out;
}

class FaceDetect : public VisionFixture {
 protected:
  void start(const std::string& config = R"({"input":"guest.camera"})") {
    startCamera();
    ASSERT_TRUE(startModule("faces", config, false, "face-detect").empty());
    waitCameraSubscriber();
    results_ = subscribe("faces.faces");
  }
  TestClient results_;
};

TEST_F(FaceDetect, FindsTheAstronautsFaceWithSeqAndCaptureTime) {
  ASSERT_NO_FATAL_FAILURE(start());
  cv::Rect face;
  const cv::Mat frame = astronautFrame(&face);
  ASSERT_TRUE(publish(jpegFrame(frame, 41, 1'700'000'000'123'456'789)));
  auto r = resultFor(results_, 41);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["capture_ns"].asInt64(), 1'700'000'000'123'456'789);
  EXPECT_EQ((*r)["width"].asInt(), 640);
  EXPECT_EQ((*r)["height"].asInt(), 360);
  const auto found = boxes(*r);
  ASSERT_EQ(found.size(), 1u) << r->toStyledString();
  // The detected box lies mostly on the face, and covers most of it.
  EXPECT_GT(coveredBy(found[0], face), 0.6) << r->toStyledString();
  EXPECT_GT(coveredBy(face, found[0]), 0.5) << r->toStyledString();
  const double score = (*r)["faces"][0]["score"].asDouble();
  EXPECT_GT(score, 0.0);
  EXPECT_LE(score, 1.0);
  EXPECT_EQ(channelInfo("faces.faces")->mime, "application/json");
}

TEST_F(FaceDetect, FindsMessiAtFullSizeAndNobodyInAnEmptyFrame) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","detect_width":0})"));
  const cv::Mat messi = cv::imread(kMessi);
  ASSERT_FALSE(messi.empty()) << kMessi;
  ASSERT_TRUE(publish(jpegFrame(messi, 1)));
  auto r = resultFor(results_, 1);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["width"].asInt(), 548);
  bool found = false;
  for (const auto& b : boxes(*r)) found = found || coveredBy(b, kMessiFace) > 0.5;
  EXPECT_TRUE(found) << r->toStyledString();

  // A frame with no face gives an empty list, not silence.
  cv::Mat noise(360, 640, CV_8UC3);
  cv::randu(noise, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(9, 9), 0);
  ASSERT_TRUE(publish(jpegFrame(noise, 2)));
  r = resultFor(results_, 2);
  ASSERT_TRUE(r);
  ASSERT_TRUE((*r)["faces"].isArray());
  EXPECT_EQ((*r)["faces"].size(), 0u) << r->toStyledString();
}

// Raw frames (bgr8 and the other colour encodings) find the faces the JPEG path finds, on the
// opencv-doc pictures.
TEST_F(FaceDetect, RawColourFramesFindTheFacesJpegFinds) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","detect_width":0})"));
  cv::Rect face;
  const cv::Mat astronaut = astronautFrame(&face);
  const cv::Mat messi = cv::imread(kMessi);
  ASSERT_FALSE(messi.empty()) << kMessi;
  std::uint64_t seq = 10;
  for (const auto& [image, truth] : {std::pair{astronaut, face}, std::pair{messi, kMessiFace}}) {
    ASSERT_TRUE(publish(jpegFrame(image, ++seq)));
    auto jpeg = resultFor(results_, seq);
    ASSERT_TRUE(jpeg);
    const auto by_jpeg = boxes(*jpeg);
    bool found = false;
    for (const auto& b : by_jpeg) found = found || coveredBy(b, truth) > 0.5;
    ASSERT_TRUE(found) << jpeg->toStyledString();
    for (const char* encoding : {"bgr8", "rgb8", "bgra8", "rgba8", "i420", "mono8"}) {
      SCOPED_TRACE(encoding);
      const std::string frame = rawFrame(image, encoding, ++seq);
      ASSERT_FALSE(frame.empty());
      ASSERT_TRUE(publish(frame));
      auto r = resultFor(results_, seq);
      ASSERT_TRUE(r);
      EXPECT_EQ((*r)["width"].asInt(), image.cols);
      // Every face the JPEG path found is found again (JPEG's losses move a box a little).
      const auto by_raw = boxes(*r);
      for (const auto& j : by_jpeg) {
        bool again = false;
        for (const auto& b : by_raw) again = again || coveredBy(j, b) > 0.7;
        EXPECT_TRUE(again) << "jpeg: " << jpeg->toStyledString() << "raw: " << r->toStyledString();
      }
    }
  }
  EXPECT_EQ(dbInt("faces", "malformed"), 0);
}

TEST_F(FaceDetect, MalformedFramesAreCountedAndSkipped) {
  ASSERT_NO_FATAL_FAILURE(start());
  cv::Rect face;
  checkMalformedSkipped(results_, "faces", astronautFrame(&face));
}

TEST_F(FaceDetect, ABurstIsAccountedForAndItsNewestFrameProcessed) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","workers":2})"));
  cv::Rect face;
  const cv::Mat frame = astronautFrame(&face);
  constexpr int kFrames = 40;
  for (int i = 0; i < kFrames; ++i) ASSERT_TRUE(publish(jpegFrame(frame, 100 + i)));
  // The newest frame is never replaced, so it is always analysed.
  auto r = resultFor(results_, 100 + kFrames - 1);
  ASSERT_TRUE(r);
  EXPECT_EQ(boxes(*r).size(), 1u);
  ASSERT_EQ(waitDb("faces", "frames", kFrames), kFrames);
  // Every frame is either analysed, skipped for a newer one, or (two workers) finished late.
  std::int64_t accounted = 0;
  for (int tries = 0; tries < 500 && accounted != kFrames; ++tries) {
    accounted = dbInt("faces", "processed") + dbInt("faces", "skipped") + dbInt("faces", "late");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(accounted, kFrames);
  EXPECT_EQ(dbInt("faces", "malformed"), 0);
}

TEST_F(FaceDetect, LbpCascadeFindsTheAstronautToo) {
  ASSERT_NO_FATAL_FAILURE(start(
      R"({"input":"guest.camera",
          "cascade":"/usr/share/opencv4/lbpcascades/lbpcascade_frontalface.xml",
          "scale_factor":1.1})"));
  cv::Rect face;
  ASSERT_TRUE(publish(jpegFrame(astronautFrame(&face), 5)));
  auto r = resultFor(results_, 5);
  ASSERT_TRUE(r);
  bool found = false;
  for (const auto& b : boxes(*r)) found = found || coveredBy(b, face) > 0.6;
  EXPECT_TRUE(found) << r->toStyledString();
}

TEST_F(FaceDetect, BadConfigFailsInitWithTheKeyAndReason) {
  startHub();
  std::string why = startFailure(
      "f1", R"({"input":"guest.camera","cascade":"/nonexistent/face.xml"})", "face-detect");
  EXPECT_NE(why.find("cascade"), std::string::npos) << why;
  EXPECT_NE(why.find("/nonexistent/face.xml"), std::string::npos) << why;

  // A file that exists but is no cascade.
  const std::string junk = (dir_.path() / "junk.xml").string();
  std::ofstream(junk) << "<opencv_storage><x>1</x></opencv_storage>\n";
  why =
      startFailure("f2", R"({"input":"guest.camera","cascade":")" + junk + R"("})", "face-detect");
  EXPECT_NE(why.find("not an OpenCV cascade"), std::string::npos) << why;

  why = startFailure("f3", R"({"input":"guest.camera","scale_factor":0.9})", "face-detect");
  EXPECT_NE(why.find("scale_factor"), std::string::npos) << why;
  why = startFailure("f4", R"({"input":"guest.camera","min_size":2})", "face-detect");
  EXPECT_NE(why.find("min_size"), std::string::npos) << why;
  why = startFailure("f5", R"({"input":"guest.camera","workers":0})", "face-detect");
  EXPECT_NE(why.find("workers"), std::string::npos) << why;
  why = startFailure("f6", R"({"input":"nodot"})", "face-detect");
  EXPECT_NE(why.find("input"), std::string::npos) << why;
  // No default input naming another module's channel: the config must say.
  why = startFailure("f7", "{}", "face-detect");
  EXPECT_NE(why.find("config.input: required key missing"), std::string::npos) << why;
  why = startFailure("f8", R"({"input":"guest.camera","scale_factr":1.1})", "face-detect");
  EXPECT_NE(why.find("config.scale_factr: unknown key (did you mean \"scale_factor\"?)"),
            std::string::npos)
      << why;
}

// The YuNet path: no model file ships with Debian, so only its refusals are tested here.
TEST_F(FaceDetect, YuNetModelThatIsMissingOrNotOnnxFailsInit) {
  startHub();
  std::string why = startFailure(
      "y1", R"({"input":"guest.camera","model":"/nonexistent/yunet.onnx"})", "face-detect");
  EXPECT_NE(why.find("model"), std::string::npos) << why;
  EXPECT_NE(why.find("cannot read model file '/nonexistent/yunet.onnx'"), std::string::npos) << why;
  const std::string junk = (dir_.path() / "junk.onnx").string();
  std::ofstream(junk) << "this is not a protobuf";
  why = startFailure("y2", R"({"input":"guest.camera","model":")" + junk + R"("})", "face-detect");
  EXPECT_NE(why.find("not a YuNet ONNX model"), std::string::npos) << why;
}

}  // namespace
}  // namespace skr::test
