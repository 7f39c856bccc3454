// SPDX-License-Identifier: Apache-2.0
// Helpers of the skrobot-asr tests and benchmark: speech made with espeak-ng and sox at run time,
// one continuous stream with silence between utterances, a hub and skrobot-asr as processes
// (tests/support/hub_process.h), and a satellite that streams the audio as media
// frames on guest.mic and collects the transcripts. Word error rate by edit distance.
#pragma once

#include "hub_process.h"

#include <json/json.h>
#include <skrobot/satellite.h>
#include <skrobot/media_frame.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace skr::asr::test {

namespace fs = std::filesystem;
using sat::test::Child;
using sat::test::HubProcess;
using skr::test::TempDir;

inline std::vector<std::int16_t> readRaw(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::int16_t> s(bytes.size() / 2);
  for (std::size_t i = 0; i < s.size(); ++i) {
    s[i] = static_cast<std::int16_t>(static_cast<unsigned char>(bytes[2 * i]) |
                                     (static_cast<unsigned char>(bytes[2 * i + 1]) << 8));
  }
  return s;
}

inline int run(const std::string& command) {
  return std::system(command.c_str());
}

// Any sound file (or raw 16 kHz s16le with raw16k) as mono s16 samples at `rate`, through sox.
inline std::vector<std::int16_t> soxTo(const fs::path& dir, const fs::path& in, int rate,
                                       bool raw16k = false) {
  static int n = 0;
  const fs::path out = dir / ("sox-" + std::to_string(++n) + ".raw");
  const std::string input = raw16k ? "-t raw -r 16000 -b 16 -e signed -c 1 '" + in.string() + "'"
                                   : "'" + in.string() + "'";
  run(std::string(SOX_BIN) + " -q " + input + " -t raw -r " + std::to_string(rate) +
      " -b 16 -e signed -c 1 '" + out.string() + "'");
  return readRaw(out);
}

// espeak-ng's rendering of `text`, at `rate` Hz.
inline std::vector<std::int16_t> speak(const fs::path& dir, const std::string& text,
                                       const std::string& voice, int speed, int rate) {
  static int n = 0;
  const fs::path wav = dir / ("speak-" + std::to_string(++n) + ".wav");
  run(std::string(ESPEAK_NG_BIN) + " -v " + voice + " -s " + std::to_string(speed) + " -w '" +
      wav.string() + "' \"" + text + "\"");
  return soxTo(dir, wav, rate);
}

struct Clip {
  std::string text;  // what was said (lower case)
  std::vector<std::int16_t> samples;
  double start_s = 0, end_s = 0;  // in the stream
};

// The clips one after the other with `gap_s` of faint noise (-70 dBFS) before, between and after.
inline std::vector<std::int16_t> concat(std::vector<Clip>& clips, double gap_s, int rate) {
  std::mt19937 rng(11);
  std::normal_distribution<double> gauss(0, std::pow(10, -70 / 20.0) * 32767);
  std::vector<std::int16_t> out;
  const auto silence = [&](double s) {
    for (int i = 0; i < static_cast<int>(s * rate); ++i) {
      out.push_back(static_cast<std::int16_t>(std::lround(gauss(rng))));
    }
  };
  silence(gap_s);
  for (auto& c : clips) {
    c.start_s = static_cast<double>(out.size()) / rate;
    out.insert(out.end(), c.samples.begin(), c.samples.end());
    c.end_s = static_cast<double>(out.size()) / rate;
    silence(gap_s);
  }
  return out;
}

inline std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> w;
  for (std::string s; in >> s;) w.push_back(s);
  return w;
}

// Word edit distance between reference and hypothesis.
inline int wordErrors(const std::string& ref, const std::string& hyp) {
  const auto r = words(ref), h = words(hyp);
  std::vector<int> prev(h.size() + 1), cur(h.size() + 1);
  for (std::size_t j = 0; j <= h.size(); ++j) prev[j] = static_cast<int>(j);
  for (std::size_t i = 1; i <= r.size(); ++i) {
    cur[0] = static_cast<int>(i);
    for (std::size_t j = 1; j <= h.size(); ++j) {
      cur[j] =
          std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (r[i - 1] == h[j - 1] ? 0 : 1)});
    }
    prev = cur;
  }
  return prev[h.size()];
}

inline Json::Value parseJson(const std::string& text) {
  Json::Value v;
  Json::CharReaderBuilder b;
  std::string errs;
  std::istringstream in(text);
  (void)Json::parseFromStream(b, in, &v, &errs);
  return v;
}

inline flow::Variant::Map micProps() {
  return {{"sample_rate", flow::Variant(std::int64_t{22050})},
          {"channels", flow::Variant(std::int64_t{1})},
          {"format", flow::Variant("s16le")}};
}

// A hub (with the config's `modules`), one skrobot-asr, and a satellite that owns guest.mic and
// reads guest.<name>.transcript.
class AsrHarness {
 public:
  AsrHarness(const TempDir& dir, std::vector<std::string> asr_args, std::string name = "asr",
             flow::Variant::Map mic_props = micProps(), const std::string& modules = "[]")
      : dir_(dir), hub_(SKROBOT_BIN, dir.path(), "", "", "", modules), name_(std::move(name)) {
    started_ = hub_.start();
    if (!started_) return;
    std::vector<std::string> argv = {ASR_BIN, "--input",   "guest.mic",   "--name",
                                     name_,   "--address", hub_.address()};
    argv.insert(argv.end(), asr_args.begin(), asr_args.end());
    asr_ = std::make_unique<Child>(argv, std::vector<std::string>{}, dir.path() / "asr.log");
    sat::SatelliteOptions options;
    options.connection.address = sat::Address::parse(hub_.address()).value();
    options.connection.client_name = "asr-test";
    sat_ = std::make_unique<sat::Satellite>(loop_, options);
    (void)sat_->addChannel({.name = "mic", .mime = "audio/L16", .props = mic_props});
    sat_->subscribe("guest." + name_ + ".transcript");
    sat_->data.connect(sat_.get(), [this](std::uint16_t, const std::string& payload) {
      Json::Value v = parseJson(payload);
      if (v.isMember("event")) {  // {"event": "started", ...}: an utterance begins
        events.push_back(std::move(v));
        return;
      }
      transcripts.push_back(std::move(v));
      arrival_ns.push_back(monotonicNs());
    });
    sat_->start();
    // Ready when skrobot-asr listens to the mic and we read its transcripts.
    started_ = loop_.runUntil(
        [&] {
          return sat_->hasSubscribers("mic") &&
                 sat_->isSubscribed("guest." + name_ + ".transcript");
        },
        30 * kNsPerSec);
  }
  ~AsrHarness() {
    if (sat_) sat_->stop();
    if (asr_) {
      asr_->signal(SIGTERM);
      asr_->wait(5000);
    }
  }
  AsrHarness(const AsrHarness&) = delete;
  AsrHarness& operator=(const AsrHarness&) = delete;
  AsrHarness(AsrHarness&&) = delete;
  AsrHarness& operator=(AsrHarness&&) = delete;

  [[nodiscard]] bool ready() const { return started_; }
  [[nodiscard]] std::string address() const { return hub_.address(); }
  [[nodiscard]] std::string hubLog() const { return hub_.log(); }
  [[nodiscard]] std::string asrLog() const { return asr_ ? asr_->output() : ""; }
  [[nodiscard]] pid_t asrPid() const { return asr_ ? asr_->pid() : -1; }
  Loop& loop() { return loop_; }
  sat::Satellite& satellite() { return *sat_; }

  // Publishes `samples` as frames of frame_ms at `speed` times real time (0: as fast as the hub
  // takes them, paced only by the queue), keeping the wall time each frame left at.
  // `every_frame` runs after each frame is queued (the bad-input test samples memory there).
  void stream(const std::vector<std::int16_t>& samples, int rate, double speed, int frame_ms = 20,
              const std::function<void(std::uint64_t seq)>& every_frame = {}) {
    const std::size_t per = static_cast<std::size_t>(rate) * frame_ms / 1000;
    const Nanos t0 = monotonicNs();
    for (std::size_t at = 0; at < samples.size(); at += per) {
      const std::size_t n = std::min(per, samples.size() - at);
      if (speed > 0) {
        const Nanos due = t0 + static_cast<Nanos>(static_cast<double>(at) / rate / speed * 1e9);
        while (monotonicNs() < due) loop_.runFor(std::min<Nanos>(due - monotonicNs(), kNsPerMs));
      }
      while (sat_->queuedBytes() > (1u << 20)) loop_.runFor(kNsPerMs);  // hub back-pressure
      media::FrameHeader h;
      h.format = media::Format::pcm_s16le;
      h.seq = seq_;
      h.channels = 1;
      h.sample_rate = static_cast<std::uint32_t>(rate);
      std::string payload(n * 2, '\0');
      for (std::size_t i = 0; i < n; ++i) {
        const auto v = static_cast<std::uint16_t>(samples[at + i]);
        payload[2 * i] = static_cast<char>(v & 0xff);
        payload[2 * i + 1] = static_cast<char>(v >> 8);
      }
      (void)sat_->publish("mic", media::makeFrame(h, payload));
      frame_sent_ns.push_back(monotonicNs());
      seq_ += n;
      if (every_frame) every_frame(seq_);
      loop_.runFor(0);
    }
  }
  // Waits until `count` transcripts arrived, or nothing arrived for quiet_ms.
  bool waitTranscripts(std::size_t count, int timeout_ms = 30000) {
    return loop_.runUntil([&] { return transcripts.size() >= count; },
                          static_cast<Nanos>(timeout_ms) * kNsPerMs);
  }
  // A control request to skrobot-asr, answered on the flow.
  flow::Variant control(const std::string& command, const flow::Variant& value = {}) {
    flow::Variant answer;
    bool done = false;
    (void)sat_->request("guest." + name_ + ".control", command, value, [&](const sat::Response& r) {
      answer = r.value;
      done = true;
    });
    loop_.runUntil([&] { return done; }, 30 * kNsPerSec);
    return answer;
  }

  std::vector<Json::Value> transcripts;  // and whatever else the satellite subscribed to
  std::vector<Json::Value> events;       // the recogniser's {"event": ...} objects
  std::vector<Nanos> arrival_ns;         // when each transcript arrived
  std::vector<Nanos> frame_sent_ns;      // when each 20 ms frame was published

 private:
  const TempDir& dir_;
  HubProcess hub_;
  std::string name_;
  bool started_ = false;
  std::unique_ptr<Child> asr_;
  Loop loop_;
  std::unique_ptr<sat::Satellite> sat_;
  std::uint64_t seq_ = 0;
};

// Resident memory of a process in KiB (VmRSS), 0 when unknown.
inline long rssKiB(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return 0;
}

// CPU time (user + system) of a process in seconds, from /proc/<pid>/stat.
inline double cpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream rest(text.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; rest >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::atof(field.c_str());
    if (i == 15) break;
  }
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// What was said, by which espeak-ng voice, at how many words a minute.
struct Said {
  std::string text;
  std::string voice;
  int speed;
};

inline std::vector<Clip> make(const TempDir& dir, const std::vector<Said>& said) {
  std::vector<Clip> clips;
  for (const auto& s : said)
    clips.push_back({s.text, speak(dir.path(), s.text, s.voice, s.speed, 22050)});
  return clips;
}

// Commands of the grammar below in three voices and speeds; the tests and the benchmark share them
// (the benchmark's other sets are other voices: docs/asr.md, Figures).
inline const std::vector<Said> kCommands = {
    {"go forward two meters", "en-us", 170},
    {"turn left", "en+f2", 130},
    {"stop", "en", 150},
    {"what do you see", "en-us", 130},
    {"move backward one meter", "en+f2", 150},
    {"look up", "en-us", 170},
    {"sit down", "en+f2", 170},
    {"turn right ninety degrees", "en", 130},
    {"say hello", "en-us", 150},
    {"wave your hand", "en+f2", 150},
    {"go forward five meters", "en", 170},
    {"stand up", "en-us", 130},
};

// The same grammar's commands in four voices that the rejection's limits were not chosen on
// (their first run came after): the recognition test's commands, and the benchmark's set 1c.
inline const std::vector<Said> kUnseenCommands = {
    {"turn left", "en+m4", 120},
    {"go forward three meters", "en+m6", 160},
    {"look down", "en+f1", 180},
    {"sit down", "en-us+m7", 150},
    {"what do you see", "en+m4", 170},
    {"move backward two meters", "en+f1", 130},
    {"stand up", "en+m6", 140},
    {"say hello", "en-us+m7", 120},
    {"turn right twenty degrees", "en+m4", 150},
    {"stop", "en+f1", 160},
    {"wave your hand", "en+m6", 180},
    {"look left", "en-us+m7", 170},
    {"go backward one meter", "en+m4", 140},
    {"look up", "en+m6", 130},
    {"turn left ninety degrees", "en+f1", 150},
    {"move forward six meters", "en-us+m7", 160},
};

// A small command grammar: what a robot mostly needs (tests and benchmark share it).
inline const char* kCommandGrammar = R"(#JSGF V1.0;
grammar robot;
public <command> = <move> | <turn> | <posture> | <look> | <social>;
<move> = (go | move) (forward | backward) [<number> (meter | meters)];
<turn> = turn (left | right) [<number> degrees];
<posture> = stop | stand up | sit down;
<look> = look (left | right | up | down);
<social> = say hello | wave your hand | what do you see;
<number> = one | two | three | four | five | six | seven | eight | nine | ten | twenty | ninety;
)";

}  // namespace skr::asr::test
