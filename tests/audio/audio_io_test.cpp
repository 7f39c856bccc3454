// SPDX-License-Identifier: Apache-2.0
// audio-io against ALSA's null device: a test HOME whose .asoundrc makes the default PCM a null
// device gives PortAudio one device on a machine without a sound card. HOME is set before main()
// runs, so before any PortAudio or ALSA initialisation in this process.
#include "audio_test_util.h"
#include "log_capture.h"

#include <cstdlib>
#include <fstream>

namespace skr::test {
namespace {

using namespace skr::test::audio;
using flow::Code;
namespace msg = flow::msg;

const std::filesystem::path& testHome() {
  static const std::filesystem::path home = [] {
    auto dir = std::filesystem::temp_directory_path() /
               ("skrobot-audio-home-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::ofstream(dir / ".asoundrc")
        << "pcm.!default { type null }\nctl.!default { type hw card 0 }\n";
    ::setenv("HOME", dir.c_str(), 1);
    static const std::string* leaked = new std::string(dir.string());  // outlives statics
    std::atexit([] { std::filesystem::remove_all(*leaked); });
    return dir;
  }();
  return home;
}
const bool kHomeSet = !testHome().empty();

class AudioIo : public ModuleFixture {
 protected:
  bool waitDbString(Listener& l, const std::string& key, const std::string& want) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(kWaitMs);
    while (std::chrono::steady_clock::now() < end) {
      if (!l.sync().call(msg::DbSelect{"aio"})) return false;
      auto v = as<msg::ReplyValue>(l.sync().call(msg::VarGet{key}));
      if (v && v->value == flow::Variant(want)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
};

TEST_F(AudioIo, CapturesAndPlaysOnTheNullDevice) {
  ASSERT_TRUE(kHomeSet);
  startHub();
  ASSERT_TRUE(
      startModule("aio", R"({"play":"guest.out","frame_samples":441})", false, "audio-io").empty());
  Listener l(flowClient(), syncClient());
  ASSERT_TRUE(waitDbString(l, "state", "running"));
  auto props = l.channelProps("aio.capture");
  ASSERT_TRUE(props);
  EXPECT_EQ(*props->find("sample_rate"), flow::Variant(int64_t{22050}));
  ASSERT_TRUE(l.subscribe("aio.capture"));

  // Capture: 0.5 s of frames of 441 samples, consecutive (what the null device reads is undefined).
  ASSERT_TRUE(l.collect([&] { return l.count("aio.capture") >= 25; }));
  std::optional<uint64_t> next;
  for (const auto& m : l.received["aio.capture"]) {
    auto f = media::parseFrame(m);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->header.sample_rate, 22050u);
    EXPECT_EQ(f->header.channels, 1u);
    EXPECT_EQ(media::sampleCount(*f), 441u);
    EXPECT_GT(f->header.capture_ns, 0);
    if (next) {
      EXPECT_EQ(f->header.seq, *next);
    }
    next = f->header.seq + 441;
  }

  // Playback: one second published on guest.out is played (and paced) on the null device.
  const uint16_t out = addChannel(l.flow(), "out");
  ASSERT_TRUE(l.flow().waitFor(Code::ev_start_publish, kWaitMs));
  const auto s = sine(440, 0.3, 22050);
  for (size_t at = 0; at < s.size(); at += 2205) {
    ASSERT_TRUE(l.flow().send(msg::Publish{out, msg::Rest{pcmFrame(s.data() + at, 2205, at)}}));
  }
  EXPECT_TRUE(l.waitDbInt("aio", "play_frames", 10));
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(kWaitMs);
  while (l.dbInt("aio", "played_samples").value_or(0) < 22050 &&
         std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(l.dbInt("aio", "played_samples"), 22050);
  EXPECT_EQ(l.dbInt("aio", "play_dropped"), 0);

  // Gaps and malformed frames on the played channel are counted, not fatal.
  ASSERT_TRUE(l.flow().send(msg::Publish{out, msg::Rest{std::string("junk")}}));
  ASSERT_TRUE(l.flow().send(msg::Publish{out, msg::Rest{pcmFrame(s.data(), 2205, 30000)}}));
  EXPECT_TRUE(l.waitDbInt("aio", "play_malformed", 1));
  EXPECT_TRUE(l.waitDbInt("aio", "play_gaps", 1));
  EXPECT_TRUE(l.waitDbInt("aio", "play_gap_samples", 30000 - 22050));
}

TEST_F(AudioIo, NoSuchDeviceIsLoggedAndTheHubGoesOn) {
  ASSERT_TRUE(kHomeSet);
  LogCapture logs;
  startHub();
  ASSERT_TRUE(startModule("aio",
                          R"({"input_device":"no-such-card","output_device":"no-such-card",)"
                          R"("play":"guest.out"})",
                          false, "audio-io")
                  .empty());
  Listener l(flowClient(), syncClient());
  ASSERT_TRUE(waitDbString(l, "state", "no-device"));
  EXPECT_TRUE(logs.sawTag("AUDIO-NO-DEVICE"));
  bool names_device = false;
  for (const auto& line : logs.lines()) {
    if (line.find("AUDIO-NO-DEVICE no input device matching 'no-such-card'") == 0) {
      names_device = true;
    }
  }
  EXPECT_TRUE(names_device);
  // The hub and the module go on: the played channel is still read and counted.
  const uint16_t out = addChannel(l.flow(), "out");
  ASSERT_TRUE(l.flow().waitFor(Code::ev_start_publish, kWaitMs));
  ASSERT_TRUE(l.flow().send(msg::Publish{out, msg::Rest{std::string("junk")}}));
  EXPECT_TRUE(l.waitDbInt("aio", "play_malformed", 1));
  EXPECT_TRUE(startModule("fft", R"({"input":"aio.capture"})", false, "fft-audio").empty());
}

}  // namespace
}  // namespace skr::test
