// SPDX-License-Identifier: Apache-2.0
// fft-audio through the hub: a satellite publishes PCM on guest.in, listens to the module's
// spectrum and bands channels, and reads its counters from the module's database.
#include "audio_test_util.h"

namespace skr::test {
namespace {

using namespace skr::test::audio;
using flow::Code;
namespace msg = flow::msg;

class FftAudio : public ModuleFixture {
 protected:
  // Starts the hub and the module, subscribes a listener to its outputs, creates guest.in and
  // waits until the module subscribed to it.
  void SetUp() override {
    startHub();
    ASSERT_TRUE(
        startModule("fft", R"({"input":"guest.in","size":1024,"hop":512})", false, "fft-audio")
            .empty());
    listener_.emplace(flowClient(), syncClient());
    ASSERT_TRUE(listener_->subscribe("fft.spectrum"));
    ASSERT_TRUE(listener_->subscribe("fft.bands"));
    in_ = addChannel(listener_->flow(), "in");
    ASSERT_TRUE(listener_->flow().waitFor(Code::ev_start_publish, kWaitMs));
  }
  void publish(const std::string& frame) {
    ASSERT_TRUE(listener_->flow().send(msg::Publish{in_, msg::Rest{frame}}));
  }
  // `count` samples of `signal` from seq `first`, in frames of 1000 samples.
  void publishSignal(const std::vector<int16_t>& signal, uint64_t first) {
    for (size_t at = 0; at < signal.size(); at += 1000) {
      const size_t n = std::min<size_t>(1000, signal.size() - at);
      publish(pcmFrame(signal.data() + at, n, first + at));
    }
  }
  std::vector<Json::Value> spectra() {
    std::vector<Json::Value> out;
    for (const auto& m : listener_->received["fft.spectrum"]) out.push_back(*parseJson(m));
    return out;
  }

  std::optional<Listener> listener_;
  uint16_t in_ = 0;
};

TEST_F(FftAudio, SineHasItsPeakInTheRightBin) {
  const double hz = 1000;
  const double amplitude = 0.5;
  publishSignal(sine(hz, amplitude, 22050), 0);
  // 22050 samples, windows of 1024 every 512: 42 windows.
  ASSERT_TRUE(listener_->collect([&] { return listener_->count("fft.spectrum") >= 42; }));
  const double bin_hz = 22050.0 / 1024;
  uint64_t expected_seq = 0;
  for (const Json::Value& s : spectra()) {
    EXPECT_EQ(s["seq"].asUInt64(), expected_seq);
    expected_seq += 512;
    EXPECT_EQ(s["sample_rate"].asUInt(), 22050u);
    ASSERT_EQ(s["bins"].size(), 513u);
    size_t peak = 1;
    for (Json::ArrayIndex k = 1; k < s["bins"].size(); ++k) {
      if (s["bins"][k].asDouble() > s["bins"][Json::ArrayIndex(peak)].asDouble()) peak = k;
    }
    EXPECT_EQ(peak, static_cast<size_t>(std::lround(hz / bin_hz)));
    EXPECT_NEAR(s["peak_hz"].asDouble(), hz, bin_hz / 2);
    // A Hann-windowed sine of amplitude A reads about A in its peak bin (scalloping < 1.5 dB).
    EXPECT_NEAR(s["bins"][Json::ArrayIndex(peak)].asDouble(), amplitude, 0.1);
    // RMS of a sine of amplitude 0.5: 20*log10(0.5/sqrt(2)) = -9.03 dBFS.
    EXPECT_NEAR(s["level_db"].asDouble(), -9.03, 0.3);
  }
  // Bands: 16 values in 0..1, the loudest one holds 1000 Hz, at most ~30 per second of audio.
  ASSERT_GE(listener_->count("fft.bands"), 1u);
  EXPECT_LE(listener_->count("fft.bands"), 31u);
  for (const auto& text : listener_->received["fft.bands"]) {
    const Json::Value b = *parseJson(text);
    ASSERT_EQ(b["bands"].size(), 16u);
    Json::ArrayIndex loudest = 0;
    for (Json::ArrayIndex i = 0; i < 16; ++i) {
      EXPECT_GE(b["bands"][i].asDouble(), 0.0);
      EXPECT_LE(b["bands"][i].asDouble(), 1.0);
      if (b["bands"][i].asDouble() > b["bands"][loudest].asDouble()) loudest = i;
    }
    // 16 log bands from 60 Hz to 11025 Hz: 1000 Hz falls in band
    // floor(16*log(1000/60)/log(11025/60)) = 8.
    EXPECT_EQ(loudest, 8u);
    EXPECT_NEAR(b["level_db"].asDouble(), -9.03, 0.3);
  }
}

TEST_F(FftAudio, SilenceHasALowLevel) {
  publishSignal(std::vector<int16_t>(4096, 0), 0);
  ASSERT_TRUE(listener_->collect([&] { return listener_->count("fft.spectrum") >= 7; }));
  for (const Json::Value& s : spectra()) EXPECT_LE(s["level_db"].asDouble(), -100);
  ASSERT_GE(listener_->count("fft.bands"), 1u);
  for (const auto& text : listener_->received["fft.bands"]) {
    for (const auto& v : (*parseJson(text))["bands"]) EXPECT_EQ(v.asDouble(), 0.0);
  }
}

TEST_F(FftAudio, GapsAreCountedAndRestartTheWindow) {
  const auto s = sine(440, 0.3, 3000);
  publish(pcmFrame(s.data(), 1000, 0));
  publish(pcmFrame(s.data() + 1000, 1000, 1000));
  publish(pcmFrame(s.data() + 2000, 1000, 2500));  // 500 samples lost
  const auto more = sine(440, 0.3, 2000, kRate, 3500);
  publishSignal(more, 3500);  // continues after the gap
  EXPECT_TRUE(listener_->waitDbInt("fft", "gaps", 1));
  EXPECT_TRUE(listener_->waitDbInt("fft", "gap_samples", 500));
  EXPECT_TRUE(listener_->waitDbInt("fft", "frames", 5));
  // Windows never straddle the gap: 0 and 512 before it; then 2500, 3012, 3524, 4036.
  ASSERT_TRUE(listener_->collect([&] { return listener_->count("fft.spectrum") >= 6; }));
  std::vector<uint64_t> seqs;
  for (const auto& sp : spectra()) seqs.push_back(sp["seq"].asUInt64());
  EXPECT_EQ(seqs, (std::vector<uint64_t>{0, 512, 2500, 3012, 3524, 4036}));
}

TEST_F(FftAudio, MalformedFramesAreCountedNotFatal) {
  publish("not a frame");
  std::string y8 =
      media::makeFrame(media::FrameHeader{media::Format::y8, 0, 0, 0, 2, 1, 0, 0}, "ab");
  publish(y8);  // a video frame on an audio channel
  const auto s = sine(440, 0.3, 1000);
  std::string half = pcmFrame(s.data(), 10, 0);
  half.pop_back();  // half a sample
  publish(half);
  publishSignal(sine(440, 0.3, 2048), 0);
  EXPECT_TRUE(listener_->waitDbInt("fft", "malformed", 3));
  ASSERT_TRUE(listener_->collect([&] { return listener_->count("fft.spectrum") >= 3; }));
}

class FftAudioConfig : public ModuleFixture {};

TEST_F(FftAudioConfig, BadValuesFailInitAndTheHubGoesOn) {
  startHub();
  auto failures = startModule("fft", R"({"size":8})", false, "fft-audio");
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_NE(failures[0].find("size"), std::string::npos) << failures[0];
  failures = startModule("fft2", R"({"window":"triangle"})", false, "fft-audio");
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_TRUE(startModule("fft3", R"({"input":"guest.x"})", false, "fft-audio").empty());
  TestClient sync = syncClient();
  EXPECT_TRUE(as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"fft3.bands"})));
}

// The input is another module's channel: the config must name it (no built-in default).
TEST_F(FftAudioConfig, TheInputIsRequired) {
  startHub();
  const auto failures = startModule("fft", "{}", false, "fft-audio");
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_NE(failures[0].find("input"), std::string::npos) << failures[0];
}

// The input's name goes into the spectrum channel's properties. Built by concatenation, a quote
// in it made the properties invalid JSON and the module failed to start.
TEST_F(FftAudioConfig, AQuoteInTheInputNameRoundTrips) {
  startHub();
  const std::string name = R"(guest.in"x\y)";
  ASSERT_TRUE(startModule("fft", R"({"input":"guest.in\"x\\y"})", false, "fft-audio").empty());
  TestClient sync = syncClient();
  auto info = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"fft.spectrum"}));
  ASSERT_TRUE(info);
  const Json::Value props = info->info.props.toJson();
  EXPECT_EQ(props["input"].asString(), name) << props.toStyledString();
  EXPECT_EQ(props["size"].asInt(), 1024);
}

}  // namespace
}  // namespace skr::test
