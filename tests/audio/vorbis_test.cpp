// SPDX-License-Identifier: Apache-2.0
// vorbis through the hub: PCM published on guest.in is recorded to .ogg files, then played back
// onto <name>.playback; duration and spectrum peak survive the round trip. soxi (from sox, which
// the project's set-up installs) checks the files independently of our decoder: without it the
// tests fail.
#include "audio_test_util.h"

#include <cstdio>
#include <cstring>

namespace skr::test {
namespace {

using namespace skr::test::audio;
using flow::Code;
namespace msg = flow::msg;

std::vector<std::filesystem::path> oggFiles(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> out;
  if (!std::filesystem::exists(dir)) return out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() == ".ogg") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Duration in samples according to soxi; -1, and a test failure, when soxi is missing or
// cannot read the file.
long soxiSamples(const std::filesystem::path& file) {
  const std::string cmd = "soxi -s '" + file.string() + "' 2>&1";
  std::FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) {
    ADD_FAILURE() << "cannot run soxi";
    return -1;
  }
  long n = -1;
  char text[512] = {};
  if (std::fscanf(p, "%ld", &n) != 1) {
    n = -1;
    (void)!std::fgets(text, sizeof text, p);
    text[std::strcspn(text, "\n")] = '\0';
  }
  const int status = ::pclose(p);
  if (n < 0 || status != 0) {
    ADD_FAILURE() << "soxi -s " << file << " failed (status " << status << ": " << text
                  << "); soxi comes with sox, which the project's set-up installs";
    return -1;
  }
  return n;
}

class Vorbis : public ModuleFixture {
 protected:
  // Records `signal` (mono, 22050 Hz) published on guest.in with recorder config `extra`;
  // returns the files written once the module stopped.
  std::vector<std::filesystem::path> record(const std::vector<int16_t>& signal,
                                            const std::string& extra = "") {
    const auto dir = dir_.path() / "rec";
    EXPECT_TRUE(startModule("rec",
                            R"({"record":"guest.in","dir":")" + dir.string() + R"(")" + extra + "}",
                            false, "vorbis")
                    .empty());
    Listener l(flowClient(), syncClient());
    const uint16_t in = addChannel(l.flow(), "in");
    EXPECT_TRUE(l.flow().waitFor(Code::ev_start_publish, kWaitMs));
    for (size_t at = 0; at < signal.size(); at += 1000) {
      const size_t n = std::min<size_t>(1000, signal.size() - at);
      EXPECT_TRUE(l.flow().send(msg::Publish{in, msg::Rest{pcmFrame(signal.data() + at, n, at)}}));
    }
    EXPECT_TRUE(l.waitDbInt("rec", "recorded_samples", static_cast<int64_t>(signal.size())));
    EXPECT_EQ(l.dbInt("rec", "gaps"), 0);
    stopModules();  // finishes the file
    return oggFiles(dir);
  }

  // Plays `file` onto play.playback and returns its samples (and checks the sample counter).
  std::vector<int16_t> play(const std::filesystem::path& file, size_t expect) {
    EXPECT_TRUE(
        startModule("play", R"({"play":")" + file.string() + R"(","lead_ms":200})", false, "vorbis")
            .empty());
    Listener l(flowClient(), syncClient());
    auto props = l.channelProps("play.playback");
    EXPECT_TRUE(props);
    if (props) {
      EXPECT_EQ(*props->find("sample_rate"), flow::Variant(int64_t{22050}));
    }
    EXPECT_TRUE(l.subscribe("play.playback"));
    std::vector<int16_t> out;
    uint64_t seq = 0;
    EXPECT_TRUE(l.collect([&] {
      auto& frames = l.received["play.playback"];
      for (const auto& m : frames) {
        auto f = media::parseFrame(m);
        EXPECT_TRUE(f);
        EXPECT_EQ(f->header.seq, seq);
        auto s = samplesOf(*f);
        seq += s.size();
        out.insert(out.end(), s.begin(), s.end());
      }
      frames.clear();
      return out.size() >= expect;
    }));
    EXPECT_TRUE(l.waitDbInt("play", "played_samples", static_cast<int64_t>(out.size())));
    stopModules();
    return out;
  }
};

TEST_F(Vorbis, RoundTripKeepsDurationAndSpectrumPeak) {
  startHub();
  const auto signal = sine(1000, 0.5, 2 * kRate);
  const auto files = record(signal);
  ASSERT_EQ(files.size(), 1u);
  EXPECT_GT(std::filesystem::file_size(files[0]), 1000u);
  EXPECT_EQ(soxiSamples(files[0]), 2 * 22050);  // sox's decoder agrees

  const auto back = play(files[0], signal.size());
  EXPECT_EQ(back.size(), signal.size());
  EXPECT_NEAR(dftPeakHz(back, 800, 1200, 2), 1000, 4);
  // The tone dominates: far above what is left at other frequencies.
  EXPECT_GT(dftMagnitude(back, 1000), 20 * dftMagnitude(back, 3000));
  EXPECT_NEAR(dftMagnitude(back, 1000), dftMagnitude(signal, 1000),
              0.1 * dftMagnitude(signal, 1000));
}

TEST_F(Vorbis, RotatesByDurationAndBySize) {
  startHub();
  // 3.5 s with a file every second of audio: four files, the last one half a second.
  auto files = record(sine(440, 0.3, 3 * kRate + kRate / 2), R"(,"rotate_s":1)");
  ASSERT_EQ(files.size(), 4u);
  long total = 0;
  for (const auto& f : files) total += soxiSamples(f);
  EXPECT_EQ(total, 3 * 22050 + 22050 / 2);
  std::filesystem::remove_all(dir_.path() / "rec");
  // By size: noise compresses badly, so 4 KB files fill quickly. The encoder writes whole Ogg
  // pages, so a file ends at the first page past the limit.
  std::vector<int16_t> noise(4 * kRate);
  uint32_t x = 1;
  for (auto& s : noise) s = static_cast<int16_t>((x = x * 1664525u + 1013904223u) >> 16);
  files = record(noise, R"(,"rotate_kb":4,"rotate_s":0)");
  ASSERT_GE(files.size(), 3u);
  for (size_t i = 0; i + 1 < files.size(); ++i)
    EXPECT_GE(std::filesystem::file_size(files[i]), 4096u);
}

TEST_F(Vorbis, GapsAndMalformedFramesAreCounted) {
  startHub();
  ASSERT_TRUE(startModule("rec",
                          R"({"record":"guest.in","dir":")" + (dir_.path() / "g").string() + "\"}",
                          false, "vorbis")
                  .empty());
  Listener l(flowClient(), syncClient());
  const uint16_t in = addChannel(l.flow(), "in");
  ASSERT_TRUE(l.flow().waitFor(Code::ev_start_publish, kWaitMs));
  const auto s = sine(440, 0.3, 3000);
  ASSERT_TRUE(l.flow().send(msg::Publish{in, msg::Rest{pcmFrame(s.data(), 1000, 0)}}));
  ASSERT_TRUE(l.flow().send(msg::Publish{in, msg::Rest{std::string("garbage")}}));
  ASSERT_TRUE(l.flow().send(msg::Publish{in, msg::Rest{pcmFrame(s.data() + 1000, 1000, 1700)}}));
  ASSERT_TRUE(l.flow().send(msg::Publish{in, msg::Rest{pcmFrame(s.data() + 2000, 1000, 2700)}}));
  EXPECT_TRUE(l.waitDbInt("rec", "malformed", 1));
  EXPECT_TRUE(l.waitDbInt("rec", "gaps", 1));
  EXPECT_TRUE(l.waitDbInt("rec", "gap_samples", 700));
  EXPECT_TRUE(l.waitDbInt("rec", "recorded_samples", 3000));
}

TEST_F(Vorbis, AFileThatIsNotOggFailsStartAndTheHubGoesOn) {
  startHub();
  const auto bad = dir_.path() / "bad.ogg";
  { std::ofstream(bad) << "not an ogg file"; }
  const auto failures = startModule("play", R"({"play":")" + bad.string() + "\"}", false, "vorbis");
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_NE(failures[0].find("not a readable Ogg Vorbis"), std::string::npos) << failures[0];
  EXPECT_TRUE(startModule("fft", R"({"input":"guest.in"})", false, "fft-audio").empty());
}

}  // namespace
}  // namespace skr::test
