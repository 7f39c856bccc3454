// SPDX-License-Identifier: Apache-2.0
// video-source (file frames, looping, props, idle without subscribers, config errors) and the
// whole chain without a browser: video-source -> video-mono -> motion + face-detect.
#include "vision_fixture.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <chrono>
#include <fstream>
#include <set>

namespace skr::test {
namespace {

constexpr int kLevels = 8;
int level(std::uint64_t i) {
  return 20 + 25 * static_cast<int>(i % kLevels);
}

// An MJPG .avi of `frames`, written with OpenCV.
std::string writeVideo(const std::filesystem::path& path, const std::vector<cv::Mat>& frames) {
  cv::VideoWriter out(path.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10,
                      frames.front().size());
  EXPECT_TRUE(out.isOpened()) << path;
  for (const auto& f : frames) out.write(f);
  return path.string();
}

std::int64_t wallNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

class VideoSource : public VisionFixture {
 protected:
  void SetUp() override {
    startHub();
    sync_ = syncClient();
  }
  // The next media frame on a subscribed video channel.
  static std::optional<std::pair<media::FrameHeader, cv::Mat>> nextFrame(TestClient& sub) {
    auto data = as<flow::msg::EvData>(sub.waitFor(flow::Code::ev_data, 30000));
    if (!data) return std::nullopt;
    auto f = media::parseFrame(data->payload.bytes);
    if (!f) return std::nullopt;
    cv::Mat image;
    if (f->header.format == media::Format::jpeg) {
      image = cv::imdecode(cv::Mat(1, static_cast<int>(f->payload.size()), CV_8UC1,
                                   const_cast<char*>(f->payload.data())),
                           cv::IMREAD_GRAYSCALE);
    } else if (f->header.format == media::Format::y8) {
      image =
          cv::Mat(f->header.height, f->header.width, CV_8UC1, const_cast<char*>(f->payload.data()))
              .clone();
    }
    return std::make_pair(f->header, image);
  }
};

TEST_F(VideoSource, PublishesJpegFramesOfTheConfiguredSizeAndLoopsTheFile) {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < kLevels; ++i)
    frames.emplace_back(240, 320, CV_8UC3, cv::Scalar::all(level(i)));
  const std::string file = writeVideo(dir_.path() / "levels.avi", frames);
  ASSERT_TRUE(startModule("src", R"({"file":")" + file + R"(","fps":60,"jpeg_quality":90})", false,
                          "video-source")
                  .empty());
  auto info = channelInfo("src.video");
  ASSERT_TRUE(info);
  EXPECT_EQ(*info->props.find("width"), flow::Variant(int64_t{640}));
  EXPECT_EQ(*info->props.find("height"), flow::Variant(int64_t{360}));
  EXPECT_EQ(info->props.find("fps")->asDouble(), 60.0);
  EXPECT_EQ(*info->props.find("pixel_format"), flow::Variant("yuvj420p"));
  EXPECT_EQ(*info->props.find("codec"), flow::Variant("jpeg"));
  EXPECT_EQ(*info->props.find("encoding"), flow::Variant("jpeg"));
  EXPECT_EQ(*info->props.find("message_encoding"), flow::Variant("skrobot.media"));
  EXPECT_EQ(info->mime, "image/jpeg");

  TestClient sub = subscribe("src.video");
  const std::int64_t before = wallNs();
  for (std::uint64_t i = 0; i < 2 * kLevels + 3; ++i) {
    auto f = nextFrame(sub);
    ASSERT_TRUE(f) << "frame " << i;
    const auto& [h, image] = *f;
    EXPECT_EQ(h.format, media::Format::jpeg);
    EXPECT_EQ(h.seq, i);
    EXPECT_EQ(h.width, 640);
    EXPECT_EQ(h.height, 360);
    EXPECT_GE(h.capture_ns, before);
    EXPECT_LE(h.capture_ns, wallNs());
    ASSERT_EQ(image.size(), cv::Size(640, 360));
    // The file's frames in order, again from the first after the last.
    EXPECT_NEAR(cv::mean(image)[0], level(i), 6) << "frame " << i;
  }
  EXPECT_GE(waitDb("src", "loops", 2), 2);
}

TEST_F(VideoSource, ReadsNothingWithoutSubscribers) {
  ASSERT_TRUE(startModule("src", std::string(R"({"file":")") + kVtest + R"(","fps":100})", false,
                          "video-source")
                  .empty());
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(dbInt("src", "frames"), 0);
  TestClient sub = subscribe("src.video");
  ASSERT_TRUE(nextFrame(sub));
  EXPECT_GE(waitDb("src", "frames", 1), 1);
}

TEST_F(VideoSource, OffersPathsWhenAsked) {
  // "paths": the hub grants a subscriber on its Unix socket shared memory to src.video (read
  // through the satellite libraries: tests/hub/module_paths_test.cpp). A frame every
  // 5 s: waiting for an answer gives up after 3 s without one.
  ASSERT_TRUE(startModule("src",
                          std::string(R"({"file":")") + kVtest + R"(","fps":0.2,"paths":"shm"})",
                          false, "video-source")
                  .empty());
  auto info = channelInfo("src.video");
  ASSERT_TRUE(info);
  TestClient sub = subscribe("src.video");
  ASSERT_TRUE(sub.send(flow::msg::PhysRequest{7, info->id, flow::msg::kPhysShm}));
  auto path = as<flow::msg::EvPhysPath>(sub.waitFor(flow::Code::ev_phys_path, 3000));
  ASSERT_TRUE(path);
  EXPECT_EQ(path->tag, 7u);
  EXPECT_EQ(path->path, flow::msg::kPhysShm);
  EXPECT_EQ(path->endpoint.rfind("unix:", 0), 0u) << path->endpoint;
  // Without "paths" it offers none: the same request is refused.
  ASSERT_TRUE(startModule("plain", std::string(R"({"file":")") + kVtest + R"(","fps":0.2})", false,
                          "video-source")
                  .empty());
  auto plain = channelInfo("plain.video");
  ASSERT_TRUE(plain);
  TestClient other = subscribe("plain.video");
  ASSERT_TRUE(other.send(flow::msg::PhysRequest{8, plain->id, flow::msg::kPhysShm}));
  auto refused = as<flow::msg::EvError>(other.waitFor(flow::Code::ev_error, 3000));
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->tag, 8u);
}

TEST_F(VideoSource, BadConfigFailsInit) {
  std::string why = startFailure("s1", R"({"file":"/nonexistent/clip.avi"})", "video-source");
  EXPECT_NE(why.find("file: no such file '/nonexistent/clip.avi'"), std::string::npos) << why;
  why = startFailure("s2", "{}", "video-source");
  EXPECT_NE(why.find("exactly one of"), std::string::npos) << why;
  why =
      startFailure("s3", std::string(R"({"file":")") + kVtest + R"(","device":0})", "video-source");
  EXPECT_NE(why.find("exactly one of"), std::string::npos) << why;
  why = startFailure("s4", std::string(R"({"file":")") + kVtest + R"(","width":641})",
                     "video-source");
  EXPECT_NE(why.find("width"), std::string::npos) << why;
  why = startFailure("s5", std::string(R"({"file":")") + kVtest + R"(","jpeg_quality":0})",
                     "video-source");
  EXPECT_NE(why.find("jpeg_quality"), std::string::npos) << why;
  why = startFailure("s6", R"({"device":"/dev/no-such-camera"})", "video-source");
  EXPECT_NE(why.find("device: OpenCV cannot open '/dev/no-such-camera'"), std::string::npos) << why;
  const std::string not_video = (dir_.path() / "notes.txt").string();
  std::ofstream(not_video) << "not a video";
  why = startFailure("s7", R"({"file":")" + not_video + R"("})", "video-source");
  EXPECT_NE(why.find("cannot open"), std::string::npos) << why;
}

// The avatar's eyes with no browser: a file through video-source, decoded once to grey by
// video-mono, which motion and face-detect share.
TEST_F(VideoSource, ChainSharesOneMonoVariantBetweenDetectors) {
  ASSERT_TRUE(startModule("src", std::string(R"({"file":")") + kVtest + R"(","fps":30})", false,
                          "video-source")
                  .empty());
  ASSERT_TRUE(startModule("mono", R"({"input":"src.video"})", false, "video-mono").empty());
  ASSERT_TRUE(startModule("motion", R"({"input":"mono.mono"})").empty());
  ASSERT_TRUE(startModule("faces", R"({"input":"mono.mono"})", false, "face-detect").empty());
  TestClient motion = subscribe("motion.motion");
  TestClient faces = subscribe("faces.faces");

  std::set<std::uint64_t> motion_seqs;
  int with_centre = 0;
  for (int i = 0; i < 30; ++i) {
    auto r = nextJson(motion);
    ASSERT_TRUE(r);
    EXPECT_EQ((*r)["width"].asInt(), 640);
    EXPECT_EQ((*r)["height"].asInt(), 360);
    EXPECT_GT((*r)["capture_ns"].asInt64(), 0);
    motion_seqs.insert((*r)["seq"].asUInt64());
    with_centre += (*r)["center"].isObject() ? 1 : 0;
  }
  EXPECT_GT(with_centre, 20) << "pedestrians walk in every frame of vtest.avi";
  // face-detect analysed frames of the same sequence (some are the very frames motion saw).
  bool shared = false;
  for (int i = 0; i < 30 && !shared; ++i) {
    auto r = nextJson(faces);
    ASSERT_TRUE(r);
    EXPECT_EQ((*r)["width"].asInt(), 640);
    shared = motion_seqs.count((*r)["seq"].asUInt64()) > 0;
  }
  EXPECT_TRUE(shared);

  // One decoder for both: the JPEG channel has one subscriber (video-mono), the grey one two.
  auto video = channelInfo("src.video");
  auto mono = channelInfo("mono.mono");
  ASSERT_TRUE(video && mono);
  EXPECT_EQ(video->subscribers, 1u);
  EXPECT_EQ(mono->subscribers, 2u);
  EXPECT_EQ(*mono->props.find("pixel_format"), flow::Variant("gray"));
  EXPECT_EQ(*mono->props.find("codec"), flow::Variant("raw"));
  EXPECT_EQ(*mono->props.find("encoding"), flow::Variant("mono8"));
  EXPECT_EQ(*mono->props.find("width"), flow::Variant(int64_t{640}));
  EXPECT_EQ(*mono->props.find("height"), flow::Variant(int64_t{360}));
  EXPECT_EQ(mono->props.find("fps")->asDouble(), 30.0);
  EXPECT_EQ(dbInt("motion", "malformed"), 0);
  EXPECT_EQ(dbInt("faces", "malformed"), 0);

  // The grey frames themselves: Y8 media frames of 640x360.
  TestClient grey = subscribe("mono.mono");
  auto f = nextFrame(grey);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->first.format, media::Format::y8);
  EXPECT_EQ(f->second.size(), cv::Size(640, 360));
  EXPECT_GT(f->first.capture_ns, 0);
}

TEST_F(VideoSource, FaceDetectFindsTheAstronautInAFile) {
  cv::Rect face;
  const cv::Mat frame = astronautFrame(&face);
  const std::string file = writeVideo(dir_.path() / "astronaut.avi", {frame, frame, frame});
  ASSERT_TRUE(
      startModule("src", R"({"file":")" + file + R"(","fps":15})", false, "video-source").empty());
  ASSERT_TRUE(startModule("faces", R"({"input":"src.video"})", false, "face-detect").empty());
  TestClient faces = subscribe("faces.faces");
  auto r = nextJson(faces);
  ASSERT_TRUE(r);
  ASSERT_EQ((*r)["faces"].size(), 1u) << r->toStyledString();
  const Json::Value& b = (*r)["faces"][0];
  const cv::Rect box(b["x"].asInt(), b["y"].asInt(), b["w"].asInt(), b["h"].asInt());
  EXPECT_GT(coveredBy(box, face), 0.6) << r->toStyledString();
}

}  // namespace
}  // namespace skr::test
