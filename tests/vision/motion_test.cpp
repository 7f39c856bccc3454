// SPDX-License-Identifier: Apache-2.0
// motion on a synthetic moving square and on the pedestrians of vtest.avi (opencv-doc), frames
// sent one at a time by a satellite on guest.camera, each result awaited before the next frame.
#include "vision_fixture.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace skr::test {
namespace {

cv::Mat squareAt(int x, int y, int side = 60) {
  cv::Mat frame(360, 640, CV_8UC3, cv::Scalar(20, 20, 20));
  cv::rectangle(frame, cv::Rect(x, y, side, side), cv::Scalar(240, 240, 240), cv::FILLED);
  return frame;
}

class Motion : public VisionFixture {
 protected:
  void start(const std::string& config = R"({"input":"guest.camera"})") {
    startCamera();
    ASSERT_TRUE(startModule("motion", config).empty());
    waitCameraSubscriber();
    results_ = subscribe("motion.motion");
  }
  // Publishes a frame and waits for its result.
  std::optional<Json::Value> analyse(const cv::Mat& frame, std::uint64_t seq) {
    EXPECT_TRUE(publish(jpegFrame(frame, seq)));
    return resultFor(results_, seq);
  }
  TestClient results_;
};

TEST_F(Motion, CentreFollowsAMovingSquare) {
  ASSERT_NO_FATAL_FAILURE(start());
  auto first = analyse(squareAt(40, 150), 0);
  ASSERT_TRUE(first);
  EXPECT_TRUE((*first)["center"].isNull());  // nothing to compare with yet
  EXPECT_EQ((*first)["amount"].asDouble(), 0.0);
  int previous_x = 40;
  for (int i = 1; i <= 20; ++i) {
    const int x = 40 + 25 * i;
    auto r = analyse(squareAt(x, 150), i);
    ASSERT_TRUE(r);
    const Json::Value& c = (*r)["center"];
    ASSERT_TRUE(c.isObject()) << r->toStyledString();
    // Differencing sees the trailing edge leave and the leading edge arrive: their middle is the
    // middle of the two positions.
    EXPECT_NEAR(c["x"].asDouble(), (previous_x + x) / 2.0 + 30, 12) << "frame " << i;
    EXPECT_NEAR(c["y"].asDouble(), 180, 12) << "frame " << i;
    const double amount = (*r)["amount"].asDouble();
    EXPECT_GT(amount, 0.005);
    EXPECT_LT(amount, 0.1);
    ASSERT_GE((*r)["regions"].size(), 1u);
    const Json::Value& b = (*r)["regions"][0];
    const cv::Rect region(b["x"].asInt(), b["y"].asInt(), b["w"].asInt(), b["h"].asInt());
    EXPECT_GT(coveredBy(cv::Rect(x, 150, 60, 60), region), 0.3) << "frame " << i;
    previous_x = x;
  }
  // A still frame: no motion at all.
  auto still = analyse(squareAt(previous_x, 150), 21);
  ASSERT_TRUE(still);
  EXPECT_EQ((*still)["amount"].asDouble(), 0.0);
  EXPECT_TRUE((*still)["center"].isNull());
  EXPECT_EQ((*still)["regions"].size(), 0u);
}

TEST_F(Motion, Mog2SeesTheSquareAgainstTheLearntBackground) {
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","method":"mog2"})"));
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(analyse(squareAt(-100, 150), i));  // background only
  for (int i = 10; i < 16; ++i) {
    const int x = 100 + 40 * (i - 10);
    auto r = analyse(squareAt(x, 150), i);
    ASSERT_TRUE(r);
    ASSERT_TRUE((*r)["center"].isObject()) << r->toStyledString();
    EXPECT_NEAR((*r)["center"]["x"].asDouble(), x + 30, 15) << "frame " << i;
  }
}

// The ground truth for vtest.avi is computed here without the module: the centroid of the pixels
// that changed by more than 25 grey levels between two consecutive frames (full resolution, no
// blur), from the same JPEG frames the module receives.
TEST_F(Motion, CentreMovesWithThePedestriansOfVtest) {
  ASSERT_NO_FATAL_FAILURE(start());
  cv::VideoCapture video(kVtest);
  ASSERT_TRUE(video.isOpened()) << kVtest;
  cv::Mat bgr, sized, previous;
  std::vector<double> errors, xs;
  for (int i = 0; i < 80; ++i) {
    ASSERT_TRUE(video.read(bgr));
    cv::resize(bgr, sized, cv::Size(640, 360), 0, 0, cv::INTER_AREA);
    const std::string frame = jpegFrame(sized, i);
    auto r = analyse(sized, i);
    ASSERT_TRUE(r);
    auto parsed = media::parseFrame(frame);
    cv::Mat grey = cv::imdecode(cv::Mat(1, static_cast<int>(parsed->payload.size()), CV_8UC1,
                                        const_cast<char*>(parsed->payload.data())),
                                cv::IMREAD_GRAYSCALE);
    if (!previous.empty()) {
      cv::Mat diff;
      cv::absdiff(grey, previous, diff);
      cv::threshold(diff, diff, 25, 255, cv::THRESH_BINARY);
      const cv::Moments m = cv::moments(diff, true);
      if (m.m00 > 200 && (*r)["center"].isObject()) {
        const double gx = m.m10 / m.m00, gy = m.m01 / m.m00;
        const double x = (*r)["center"]["x"].asDouble(), y = (*r)["center"]["y"].asDouble();
        errors.push_back(std::hypot(x - gx, y - gy));
        xs.push_back(x);
      }
    }
    previous = grey;
  }
  ASSERT_GE(errors.size(), 60u) << "the module saw no motion in most frames";
  std::sort(errors.begin(), errors.end());
  std::printf("vtest: %zu frames compared, distance to ground truth median %.1f px, p90 %.1f px\n",
              errors.size(), errors[errors.size() / 2], errors[errors.size() * 9 / 10]);
  EXPECT_LT(errors[errors.size() / 2], 25.0) << "median distance to the ground truth";
  EXPECT_LT(errors[errors.size() * 9 / 10], 60.0) << "90th percentile distance";
  // People walk: the centre travels.
  const auto [lo, hi] = std::minmax_element(xs.begin(), xs.end());
  EXPECT_GT(*hi - *lo, 20.0);
}

TEST_F(Motion, MaxFpsDropsFramesThatComeTooSoon) {
  // One frame per 100 s: the first of a burst is analysed, the others are limited.
  ASSERT_NO_FATAL_FAILURE(start(R"({"input":"guest.camera","max_fps":0.01})"));
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(publish(jpegFrame(squareAt(10 * i, 100), i)));
  ASSERT_EQ(waitDb("motion", "frames", 5), 5);
  EXPECT_EQ(waitDb("motion", "limited", 4), 4);
  EXPECT_EQ(waitDb("motion", "processed", 1), 1);
  auto r = nextJson(results_);
  ASSERT_TRUE(r);
  EXPECT_EQ((*r)["seq"].asUInt64(), 0u);
}

TEST_F(Motion, MalformedFramesAreCountedAndSkipped) {
  ASSERT_NO_FATAL_FAILURE(start());
  checkMalformedSkipped(results_, "motion", squareAt(100, 100));
}

TEST_F(Motion, BadConfigFailsInit) {
  startHub();
  std::string why =
      startFailure("m1", R"({"input":"guest.camera","method":"optical-flow"})", "motion");
  EXPECT_NE(why.find("method"), std::string::npos) << why;
  why = startFailure("m2", R"({"input":"guest.camera","workers":2})", "motion");
  EXPECT_NE(why.find("config.workers: must be <= 1, got 2"), std::string::npos) << why;
  why = startFailure("m3", R"({"input":"guest.camera","threshold":0})", "motion");
  EXPECT_NE(why.find("threshold"), std::string::npos) << why;
  why = startFailure("m4", R"({"input":"guest.camera","max_fps":-1})", "motion");
  EXPECT_NE(why.find("max_fps"), std::string::npos) << why;
}

}  // namespace
}  // namespace skr::test
