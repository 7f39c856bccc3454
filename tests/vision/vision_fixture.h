// SPDX-License-Identifier: Apache-2.0
// Helpers for the vision module tests: a satellite that publishes media frames on guest.camera,
// a satellite subscribed to a module's results, and the test data of Debian's packages.
#pragma once

#include "module_fixture.h"

#include <skrobot/media_frame.hpp>

#include <json/json.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace skr::test {

inline const char* const kAstronaut = "/usr/lib/python3/dist-packages/skimage/data/astronaut.png";
inline const char* const kMessi = "/usr/share/doc/opencv-doc/examples/data/messi5.jpg";
inline const char* const kVtest = "/usr/share/doc/opencv-doc/examples/data/vtest.avi";
// The face in astronaut.png (512x512), drawn by hand around forehead, cheeks and chin.
inline const cv::Rect kAstronautFace(170, 55, 110, 130);
// Messi's face in messi5.jpg (548x342).
inline const cv::Rect kMessiFace(205, 62, 62, 58);

// astronaut.png scaled to 360x360 in the middle of a grey 640x360 frame; `face` is where the
// hand-drawn face box lands.
inline cv::Mat astronautFrame(cv::Rect* face) {
  const cv::Mat src = cv::imread(kAstronaut);
  EXPECT_FALSE(src.empty()) << kAstronaut;
  const double s = 360.0 / src.rows;
  const int x0 = 140;
  cv::Mat frame(360, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  cv::Mat sized;
  cv::resize(src, sized, cv::Size(360, 360), 0, 0, cv::INTER_AREA);
  sized.copyTo(frame(cv::Rect(x0, 0, 360, 360)));
  *face = cv::Rect(x0 + cvRound(kAstronautFace.x * s), cvRound(kAstronautFace.y * s),
                   cvRound(kAstronautFace.width * s), cvRound(kAstronautFace.height * s));
  return frame;
}

// A media frame holding `image` as JPEG (BGR or grey).
inline std::string jpegFrame(const cv::Mat& image, std::uint64_t seq, std::int64_t capture_ns = 0,
                             int quality = 90) {
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality});
  media::FrameHeader h;
  h.format = media::Format::jpeg;
  h.seq = seq;
  h.capture_ns = capture_ns;
  h.width = static_cast<std::uint16_t>(image.cols);
  h.height = static_cast<std::uint16_t>(image.rows);
  return media::makeFrame(h, std::string(jpeg.begin(), jpeg.end()));
}

// A media frame holding `grey` (CV_8UC1) as Y8 pixels, as video-mono publishes them.
inline std::string y8Frame(const cv::Mat& grey, std::uint64_t seq) {
  const cv::Mat pixels = grey.isContinuous() ? grey : grey.clone();
  media::FrameHeader h;
  h.format = media::Format::y8;
  h.seq = seq;
  h.width = static_cast<std::uint16_t>(pixels.cols);
  h.height = static_cast<std::uint16_t>(pixels.rows);
  return media::makeFrame(
      h, std::string_view(reinterpret_cast<const char*>(pixels.data), pixels.total()));
}

// A raw media frame of `encoding` ("bgr8", "rgb8", ...) holding `bgr` (CV_8UC3), converted as
// a camera would deliver it.
inline std::string rawFrame(const cv::Mat& bgr, std::string_view encoding, std::uint64_t seq) {
  const auto* info = media::encodingInfo(encoding);
  cv::Mat pixels;
  if (encoding == "bgr8") pixels = bgr.clone();
  if (encoding == "rgb8") cv::cvtColor(bgr, pixels, cv::COLOR_BGR2RGB);
  if (encoding == "rgba8") cv::cvtColor(bgr, pixels, cv::COLOR_BGR2RGBA);
  if (encoding == "bgra8") cv::cvtColor(bgr, pixels, cv::COLOR_BGR2BGRA);
  if (encoding == "mono8") cv::cvtColor(bgr, pixels, cv::COLOR_BGR2GRAY);
  if (encoding == "i420") cv::cvtColor(bgr, pixels, cv::COLOR_BGR2YUV_I420);
  if (info == nullptr || pixels.empty()) return {};
  auto msg = media::makeRawFrame(info->format, static_cast<std::uint16_t>(bgr.cols),
                                 static_cast<std::uint16_t>(bgr.rows),
                                 std::string_view(reinterpret_cast<const char*>(pixels.data),
                                                  pixels.total() * pixels.elemSize()),
                                 seq);
  return msg ? *msg : std::string();
}

// The area of `a` covered by `b`, as a fraction of `a`.
inline double coveredBy(const cv::Rect& a, const cv::Rect& b) {
  return a.area() > 0 ? static_cast<double>((a & b).area()) / a.area() : 0.0;
}

inline std::optional<Json::Value> parseJson(std::string_view text) {
  Json::CharReaderBuilder builder;
  std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value v;
  std::string errors;
  if (!reader->parse(text.data(), text.data() + text.size(), &v, &errors)) return std::nullopt;
  return v;
}

class VisionFixture : public ModuleFixture {
 protected:
  // Starts the hub and the camera satellite (guest.camera).
  void startCamera() {
    startHub();
    camera_ = flowClient();
    camera_id_ = addChannel(camera_, "camera");
    sync_ = syncClient();
  }

  // Waits until a module subscribed to guest.camera.
  void waitCameraSubscriber() { ASSERT_TRUE(camera_.waitFor(flow::Code::ev_start_publish, 20000)); }

  bool publish(const std::string& message) {
    return camera_.send(flow::msg::Publish{camera_id_, flow::msg::Rest{message}});
  }

  // A new flow subscribed to `channel` (full name).
  TestClient subscribe(const std::string& channel) {
    TestClient c = flowClient();
    auto info = as<flow::msg::ChannelInfoReply>(sync_.call(flow::msg::ChanInfoByName{channel}));
    EXPECT_TRUE(info) << "no channel " << channel;
    if (info) {
      EXPECT_TRUE(c.send(flow::msg::Subscribe{1, info->info.id}));
    }
    return c;
  }

  std::optional<flow::msg::ChannelInfo> channelInfo(const std::string& channel) {
    auto info = as<flow::msg::ChannelInfoReply>(sync_.call(flow::msg::ChanInfoByName{channel}));
    if (!info) return std::nullopt;
    return info->info;
  }

  // The next message on a subscribed channel, as JSON. Generous timeout: Debug builds and a
  // loaded machine are slow, and no test relies on speed.
  static std::optional<Json::Value> nextJson(TestClient& sub, int timeout_ms = 30000) {
    auto data = as<flow::msg::EvData>(sub.waitFor(flow::Code::ev_data, timeout_ms));
    if (!data) return std::nullopt;
    return parseJson(data->payload.bytes);
  }
  // Skips results until the one for frame `seq`.
  static std::optional<Json::Value> resultFor(TestClient& sub, std::uint64_t seq,
                                              int timeout_ms = 30000) {
    for (;;) {
      auto v = nextJson(sub, timeout_ms);
      if (!v || (*v)["seq"].asUInt64() == seq) return v;
    }
  }

  // An integer of a database, or -1.
  std::int64_t dbInt(const std::string& db, const std::string& key) {
    if (sync_.call(flow::msg::DbSelect{db})->kind() != flow::Code::reply_ok) return -1;
    auto v = as<flow::msg::ReplyValue>(sync_.call(flow::msg::VarGet{key}));
    if (!v) return -1;
    return v->value.asInt64().value_or(-1);
  }
  // Polls a counter until it reaches `want` (or the timeout); returns its last value.
  std::int64_t waitDb(const std::string& db, const std::string& key, std::int64_t want,
                      int timeout_ms = 30000) {
    std::int64_t v = -1;
    for (int waited = 0; waited <= timeout_ms; waited += 20) {
      v = dbInt(db, key);
      if (v >= want) return v;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return v;
  }

  // "<module> [MODULE-INIT]: <reason>" lines of a module that should not start.
  std::string startFailure(const std::string& name, const std::string& config,
                           const std::string& file = {}) {
    const auto failures = startModule(name, config, false, file);
    return failures.empty() ? std::string() : failures.front();
  }

  // Sends what a detector must refuse (not a media frame, a corrupt JPEG, audio), then `good`,
  // and checks that the module goes on: the result for `good` (seq 777) arrives on `results`
  // and database `db` counts three malformed frames out of four.
  void checkMalformedSkipped(TestClient& results, const std::string& db, const cv::Mat& good) {
    ASSERT_TRUE(publish("not a media frame"));
    media::FrameHeader pcm;
    pcm.format = media::Format::pcm_s16le;
    pcm.seq = 775;
    pcm.channels = 1;
    pcm.sample_rate = 22050;
    ASSERT_TRUE(publish(media::makeFrame(pcm, std::string(64, '\0'))));
    media::FrameHeader h;
    h.format = media::Format::jpeg;
    h.seq = 776;
    h.width = 640;
    h.height = 360;
    ASSERT_TRUE(publish(media::makeFrame(h, std::string("\xff\xd8\xff\xe0 this is no JPEG"))));
    // The corrupt JPEG is found by a worker: wait for it, or the good frame could replace it in
    // the slot (and it would count as skipped).
    EXPECT_EQ(waitDb(db, "malformed", 3), 3);
    ASSERT_TRUE(publish(jpegFrame(good, 777)));
    auto r = resultFor(results, 777);
    ASSERT_TRUE(r) << "no result after malformed frames";
    EXPECT_EQ(dbInt(db, "frames"), 4);
    EXPECT_EQ(dbInt(db, "processed"), 1);
    EXPECT_EQ(dbInt(db, "malformed"), 3);
    EXPECT_EQ(dbInt(db, "skipped"), 0);
  }

  TestClient camera_;
  TestClient sync_;
  std::uint16_t camera_id_ = 0;
};

}  // namespace skr::test
