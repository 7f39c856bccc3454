// SPDX-License-Identifier: Apache-2.0
// flowctl record and play against a real hub: a recorder killed mid-run leaves a file readable up
// to its last chunk, a recorder stopped with SIGINT a complete one, and play publishes it again
// (remapped) with its timing, contents and properties.
#include <skrobot/mcap/reader.h>
#include <skrobot/media_frame.hpp>

#include <algorithm>
#include <csignal>
#include <mutex>

#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

using flow::Variant;

constexpr int kMessages = 60;
constexpr int kPeriodMs = 10;

struct Received {
  std::string channel, payload;
  Nanos at = 0;
};

class FlowctlRecord : public SatTest {
 protected:
  void SetUp() override { startHub(); }

  std::unique_ptr<Child> flowctl(std::vector<std::string> args) {
    args.insert(args.begin(), FLOWCTL_BIN);
    return std::make_unique<Child>(args, std::vector<std::string>{"ROBOT_ADDRESS=" + address()},
                                   dir_.path() / ("flowctl-" + std::to_string(++runs_) + ".out"));
  }

  // guest.numbers (JSON) and guest.video (media frames), with properties.
  std::unique_ptr<SatOnThread> publisher() {
    auto s = satellite("camera");
    s->on([](Satellite& x) {
      ASSERT_TRUE(x.addChannel(
          {.name = "numbers", .mime = "application/json", .props = Variant::Map{{"unit", "n"}}}));
      ASSERT_TRUE(x.addChannel(
          {.name = "video", .mime = "image/jpeg", .props = Variant::Map{{"width", 4}}}));
    });
    EXPECT_TRUE(eventually([&] { return s->events.count("ready:") == 2; }));
    return s;
  }
  static std::string number(int i) { return "{\"n\":" + std::to_string(i) + "}"; }
  static int64_t captureNs(int i) { return 1'700'000'000'000'000'000 + int64_t(i) * 1'000'000; }
  static std::string frame(int i) {
    media::FrameHeader h;
    h.seq = static_cast<uint64_t>(i);
    h.capture_ns = captureNs(i);
    h.width = 2;
    h.height = 2;
    return media::makeFrame(h, "jpeg" + std::to_string(i));
  }
  // Publishes kMessages on both channels, kPeriodMs apart; the numbers' unit changes halfway.
  void publish(SatOnThread& s) {
    for (int i = 0; i < kMessages; ++i) {
      s.on([&](Satellite& x) {
        ASSERT_TRUE(x.publish("numbers", number(i)));
        ASSERT_TRUE(x.publish("video", frame(i)));
        if (i == kMessages / 2) {
          ASSERT_TRUE(x.setChannelProperties("numbers", {{"unit", "m"}}));
        }
      });
      std::this_thread::sleep_for(std::chrono::milliseconds(kPeriodMs));
    }
  }
  // Waits until the recorder subscribed to both channels.
  void waitForRecorder(SatOnThread& s) {
    EXPECT_TRUE(eventually([&] { return s.events.count("start:") == 2; })) << hubLog();
  }

  int runs_ = 0;
};

// The messages a streaming read finds, as channel name + payload.
std::vector<std::pair<std::string, std::string>> streamed(const std::string& path,
                                                          mcap::ScanEnd& end) {
  std::vector<std::pair<std::string, std::string>> out;
  auto reader = mcap::Reader::open(path);
  EXPECT_TRUE(reader) << reader.error().message;
  if (!reader) return out;
  std::map<uint16_t, std::string> topics;
  auto r = reader->scan({.channel = [&](const mcap::Channel& c) { topics[c.id] = c.topic; },
                         .message =
                             [&](const mcap::Message& m) {
                               out.emplace_back(topics.at(m.channel_id), std::string(m.data));
                               if (topics.at(m.channel_id) == "guest.video") {
                                 auto f = media::parseFrame(m.data);
                                 ASSERT_TRUE(f);
                                 EXPECT_EQ(m.publish_time, uint64_t(f->header.capture_ns));
                               } else {
                                 EXPECT_EQ(m.publish_time, m.log_time);
                               }
                             }});
  EXPECT_TRUE(r) << r.error().message;
  if (r) end = *r;
  return out;
}

// In order per channel, the first n of what was published.
void expectPrefix(const std::vector<std::pair<std::string, std::string>>& got) {
  int numbers = 0, frames = 0;
  for (const auto& [channel, payload] : got) {
    if (channel == "guest.numbers") {
      EXPECT_EQ(payload, "{\"n\":" + std::to_string(numbers++) + "}");
    } else {
      auto f = media::parseFrame(payload);
      ASSERT_TRUE(f);
      EXPECT_EQ(f->header.seq, uint64_t(frames++));
    }
  }
}

TEST_F(FlowctlRecord, KilledRecorderLeavesAReadableFile) {
  auto pub = publisher();
  const std::string path = (dir_.path() / "killed.mcap").string();
  auto rec = flowctl({"record", "-o", path, "guest.numbers", "guest.video", "--flush-ms", "100",
                      "--compression", "lz4"});
  waitForRecorder(*pub);
  publish(*pub);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));  // at least one flush after
  rec->signal(SIGKILL);
  rec->wait();
  auto reader = mcap::Reader::open(path);
  ASSERT_TRUE(reader);
  EXPECT_EQ(reader->readSummary().error().code, Errc::not_found);
  mcap::ScanEnd end;
  const auto got = streamed(path, end);
  EXPECT_FALSE(end.complete);
  // Everything was flushed before the kill: every message is there, in order.
  EXPECT_EQ(got.size(), size_t(2 * kMessages)) << end.stopped;
  expectPrefix(got);
}

TEST_F(FlowctlRecord, RecordThenPlayRemapped) {
  auto pub = publisher();
  const std::string path = (dir_.path() / "run.mcap").string();
  auto rec = flowctl({"--json", "record", "-o", path, "guest.*"});
  waitForRecorder(*pub);
  const Nanos published_from = monotonicNs();
  publish(*pub);
  const double published_s = double(monotonicNs() - published_from) / 1e9;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  rec->signal(SIGINT);
  ASSERT_EQ(rec->wait(), 0) << rec->output();
  EXPECT_NE(rec->output().find("\"dropped\":0"), std::string::npos) << rec->output();

  auto reader = mcap::Reader::open(path);
  ASSERT_TRUE(reader);
  auto summary = reader->readSummary();
  ASSERT_TRUE(summary) << summary.error().message;
  ASSERT_TRUE(summary->statistics);
  EXPECT_EQ(summary->statistics->message_count, uint64_t(2 * kMessages));
  std::vector<std::string> units;
  for (const auto& m : summary->metadata) {
    auto meta = reader->readMetadata(m);
    ASSERT_TRUE(meta);
    if (meta->metadata.at("channel") == "guest.numbers") {
      units.push_back(meta->metadata.at("properties"));
    }
  }
  EXPECT_EQ(units, (std::vector<std::string>{"{\"unit\":\"n\"}", "{\"unit\":\"m\"}"}));
  mcap::ScanEnd end;
  auto got = streamed(path, end);
  EXPECT_TRUE(end.complete) << end.stopped;
  EXPECT_EQ(got.size(), size_t(2 * kMessages));
  expectPrefix(got);

  // Play: guest.numbers as guest.again, guest.video as the player's own guest.video (the
  // publisher is gone).
  pub.reset();
  EXPECT_TRUE(eventually([&] {
    return !flowctl({"ls", "guest.video"})->waitOutput("guest.video", 200);
  }));
  auto sub = satellite("detector");
  std::mutex m;
  std::vector<Received> received;
  sub->on([&](Satellite& x) {
    x.data.connect(&x, [&x, &m, &received](uint16_t id, const std::string& payload) {
      std::lock_guard lock(m);
      received.push_back({x.channel(id)->name, payload, monotonicNs()});
    });
    x.subscribe("guest.again");
    x.subscribe("guest.video");
    x.follow("guest.clock");
  });
  auto play = flowctl({"--json", "play", path, "--remap", "guest.numbers=again", "--wait-ms",
                       "5000", "--sync", "clock", "--sync-hz", "50"});
  ASSERT_EQ(play->wait(), 0) << play->output();
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(m);
    return received.size() == size_t(2 * kMessages);
  })) << play->output();
  std::lock_guard lock(m);
  std::vector<std::pair<std::string, std::string>> replayed;
  for (const auto& r : received) {
    replayed.emplace_back(r.channel == "guest.again" ? "guest.numbers" : r.channel, r.payload);
  }
  EXPECT_EQ(replayed, got);  // the same messages in the same order
  // The recorded timing, roughly: the span of the run within 40% (and 150 ms).
  const double span_s = double(received.back().at - received.front().at) / 1e9;
  EXPECT_NEAR(span_s, published_s, std::max(0.4 * published_s, 0.15)) << play->output();
  // The sync source pulsed 50 times per recorded second.
  const double pulses = double(sub->events.count("pulse:guest.clock:"));
  EXPECT_NEAR(pulses, 50 * published_s, 0.4 * 50 * published_s + 3) << play->output();
  // The properties changed as they did while recording.
  EXPECT_EQ(sub->events.count("changed:guest.again:{\"unit\":\"m\"}"), 1u);
}

// --rate, --start, --channels and --loop on a recording of 60 messages 10 ms apart.
TEST_F(FlowctlRecord, PlayOptions) {
  auto pub = publisher();
  const std::string path = (dir_.path() / "options.mcap").string();
  auto rec = flowctl({"record", "-o", path, "guest.numbers", "guest.video"});
  waitForRecorder(*pub);
  publish(*pub);
  rec->signal(SIGINT);
  ASSERT_EQ(rec->wait(), 0) << rec->output();
  pub.reset();
  // The recording's span, from its log times.
  std::vector<uint64_t> times;
  {
    auto reader = mcap::Reader::open(path);
    ASSERT_TRUE(reader);
    ASSERT_TRUE(
        reader->scan({.message = [&](const mcap::Message& m) { times.push_back(m.log_time); }}));
  }
  ASSERT_EQ(times.size(), size_t(2 * kMessages));
  const double span_s = double(times.back() - times.front()) / 1e9;
  const uint64_t start_ns = times.front() + uint64_t(span_s / 2 * 1e9);
  const auto second_half = static_cast<size_t>(
      std::count_if(times.begin(), times.end(), [&](uint64_t t) { return t >= start_ns; }));

  auto sub = satellite("detector");
  std::mutex m;
  std::vector<Received> received;
  sub->on([&](Satellite& x) {
    x.data.connect(&x, [&x, &m, &received](uint16_t id, const std::string& payload) {
      std::lock_guard lock(m);
      received.push_back({x.channel(id)->name, payload, monotonicNs()});
    });
    x.subscribe("guest.numbers");
  });
  // Twice as fast, from the middle, the numbers only (no subscriber waits for the video).
  auto play = flowctl({"--json", "play", path, "--rate", "2", "--start", std::to_string(span_s / 2),
                       "--channels", "*.numbers"});
  ASSERT_EQ(play->wait(), 0) << play->output();
  EXPECT_EQ(play->output().find("video"), std::string::npos) << play->output();
  {
    std::lock_guard lock(m);
    // The numbers of the second half (one either way: the cut falls between two messages).
    EXPECT_NEAR(double(received.size()), double(second_half) / 2, 1.5) << play->output();
    ASSERT_GE(received.size(), 2u);
    const double played_s = double(received.back().at - received.front().at) / 1e9;
    EXPECT_NEAR(played_s, span_s / 4, std::max(0.4 * span_s / 4, 0.1)) << play->output();
    received.clear();
  }
  // --loop: again and again until SIGINT.
  auto looping = flowctl({"play", path, "--loop", "--rate", "4", "--channels", "guest.numbers"});
  EXPECT_TRUE(eventually([&] {
    std::lock_guard lock(m);
    return received.size() > size_t(2 * kMessages);
  })) << looping->output();
  looping->signal(SIGINT);
  EXPECT_EQ(looping->wait(), 0) << looping->output();
}

// A disk that does not keep up (here: a queue too small for any message) drops, and says so.
TEST_F(FlowctlRecord, DropsAreCountedAndReported) {
  auto pub = publisher();
  const std::string path = (dir_.path() / "drops.mcap").string();
  auto rec = flowctl({"--json", "record", "-o", path, "guest.video", "--queue-mb", "0.00001"});
  EXPECT_TRUE(eventually([&] { return pub->events.count("start:guest.video") == 1; }));
  for (int i = 0; i < 5; ++i)
    pub->on([&](Satellite& x) { ASSERT_TRUE(x.publish("video", frame(i))); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  rec->signal(SIGTERM);
  EXPECT_EQ(rec->wait(), 0);
  EXPECT_NE(rec->output().find("\"dropped\":5"), std::string::npos) << rec->output();
  EXPECT_NE(rec->output().find("5 messages dropped: the disk did not keep up"), std::string::npos)
      << rec->output();
  // The file is complete (SIGTERM finishes it) and holds the channel but no message.
  auto reader = mcap::Reader::open(path);
  ASSERT_TRUE(reader);
  auto summary = reader->readSummary();
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->channels.size(), 1u);
  EXPECT_EQ(summary->statistics->message_count, 0u);
}

// A recorded channel that someone publishes now: play says which and how to remap it, and does
// not claim to have played anything.
TEST_F(FlowctlRecord, PlayOntoAChannelThatExistsSuggestsRemap) {
  auto pub = publisher();
  const std::string path = (dir_.path() / "short.mcap").string();
  auto rec = flowctl({"record", "-o", path, "guest.numbers"});
  EXPECT_TRUE(eventually([&] { return pub->events.count("start:") >= 1; })) << hubLog();
  pub->on([](Satellite& x) { ASSERT_TRUE(x.publish("numbers", number(1))); });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  rec->signal(SIGINT);
  ASSERT_EQ(rec->wait(), 0) << rec->output();
  auto play = flowctl({"play", path, "--wait-ms", "100"});  // guest.numbers still has its owner
  EXPECT_NE(play->wait(), 0) << play->output();
  EXPECT_NE(play->output().find("channel guest.numbers exists"), std::string::npos)
      << play->output();
  EXPECT_NE(play->output().find("--remap guest.numbers=numbers_replay"), std::string::npos)
      << play->output();
  EXPECT_EQ(play->output().find("played 0 messages"), std::string::npos) << play->output();
}

TEST_F(FlowctlRecord, UsageErrors) {
  EXPECT_EQ(flowctl({"record", "guest.x"})->wait(), 2);       // no -o
  EXPECT_EQ(flowctl({"record", "-o", "x.mcap"})->wait(), 2);  // no channel
  EXPECT_EQ(flowctl({"record", "-o", "x.mcap", "a.b", "--compression", "rar"})->wait(), 2);
  EXPECT_EQ(flowctl({"play"})->wait(), 2);
  EXPECT_EQ(flowctl({"play", (dir_.path() / "none.mcap").string()})->wait(), 1);
  auto bad = flowctl({"play", "x.mcap", "--remap", "nothing"});
  EXPECT_EQ(bad->wait(), 2);
}

}  // namespace
}  // namespace skr::sat::test
