// SPDX-License-Identifier: Apache-2.0
// fft-audio: the spectrum of an audio channel (docs/audio.md).
//   input:  the channel named by config "input" (required), PCM media frames
//   output: <name>.spectrum (JSON per window), <name>.bands (JSON, 16 bands, <= bands_rate_hz/s)
// The loop thread parses frames and counts gaps; a worker thread runs the FFT (one FFTW plan,
// made at init) and posts the JSON back to the loop thread, which publishes it. Nothing is
// analysed while neither output has a subscriber.
#include <skrobot/audio/bounded_queue.h>
#include <skrobot/audio/input_stats.h>
#include "spectrum_analyser.h"

#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <atomic>
#include <memory>
#include <string>
#include <thread>

namespace {

using skr::plugin::Failure;

// What the two channels carry (docs/audio.md), as typed channels declare it (docs/channels.md).
constexpr const char* kSpectrumSchema =
    R"({"$schema":"http://json-schema.org/draft-07/schema#","title":"skrobot.audio.Spectrum",)"
    R"("description":"One window's amplitude spectrum, docs/audio.md","type":"object",)"
    R"("required":["seq","capture_ns","sample_rate","size","level_db","peak_hz","bins"],)"
    R"("properties":{"seq":{"type":"integer","minimum":0},"capture_ns":{"type":"integer"},)"
    R"("sample_rate":{"type":"integer","minimum":1},"size":{"type":"integer","minimum":2},)"
    R"("level_db":{"type":"number","maximum":0},"peak_hz":{"type":"number","minimum":0},)"
    R"("bins":{"type":"array","items":{"type":"number","minimum":0}}}})";
constexpr const char* kBandsSchema =
    R"({"$schema":"http://json-schema.org/draft-07/schema#","title":"skrobot.audio.Bands",)"
    R"("description":"16 log-spaced band levels in 0..1, docs/audio.md","type":"object",)"
    R"("required":["seq","level_db","bands"],"properties":{"seq":{"type":"integer",)"
    R"("minimum":0},"level_db":{"type":"number","maximum":0},"bands":{"type":"array",)"
    R"("minItems":16,"maxItems":16,"items":{"type":"number","minimum":0,"maximum":1}}}})";
using skr::plugin::Host;

// The host has checked the config against kConfig (types, ranges, choices) and filled in the
// defaults; what is left here is what the declaration cannot say.
skr::audio::AnalyserOptions readOptions(Host& host) {
  skr::audio::AnalyserOptions o;
  const std::int64_t size = host.configInt("size");
  o.size = static_cast<std::size_t>(size);
  const std::int64_t hop = host.configInt("hop", size / 2);
  if (hop > size) {
    host.configError("hop",
                     "must be 1..size (" + std::to_string(size) + "), got " + std::to_string(hop));
    throw Failure(SKR_ERR_CONFIG, "invalid hop");
  }
  o.hop = static_cast<std::size_t>(hop);
  const auto w = skr::audio::windowFromName(host.configString("window"));
  if (!w) throw Failure(SKR_ERR_CONFIG, "invalid window");  // the host checked the choices
  o.window = *w;
  o.bands_rate_hz = host.configDouble("bands_rate_hz");
  o.min_db = host.configDouble("min_db");
  return o;
}

class FftAudio final : public skr::plugin::Module {
 public:
  explicit FftAudio(Host& host)
      : host_(host),
        input_(host.configString("input")),
        analyser_(std::make_unique<skr::audio::SpectrumAnalyser>(readOptions(host))),
        queue_(static_cast<std::size_t>(host.configInt("queue_max"))) {}

  void start() override {
    using namespace skr::plugin;
    const auto& o = analyser_->options();
    Json::Value props(Json::objectValue);
    props["size"] = Json::UInt64(o.size);
    props["hop"] = Json::UInt64(o.hop);
    props["input"] = input_;
    skr::support::addTypeProperties(
        props, {"json", "skrobot.audio.Spectrum", "jsonschema", kSpectrumSchema});
    spectrum_ =
        StreamChannel(host_, "spectrum", "application/json", skr::support::writeJson(props));
    Json::Value bands(Json::objectValue);
    bands["bands"] = 16;
    skr::support::addTypeProperties(bands,
                                    {"json", "skrobot.audio.Bands", "jsonschema", kBandsSchema});
    bands_ = StreamChannel(host_, "bands", "application/json", skr::support::writeJson(bands));
    worker_ = std::thread([this] { work(); });
    in_ = Subscription(host_, input_, [this](std::string_view msg) { onFrame(msg); });
    stats_tick_ = host_.onTick(skr::plugin::Tick::one_sec, [this] { writeStats(); });
    host_.log.info("FFT-START", "spectrum of ", input_, ": size ", o.size, ", hop ", o.hop);
  }

  void stop() override {
    in_.reset();
    queue_.close();
    if (worker_.joinable()) worker_.join();
    stats_tick_.reset();
    writeStats();
    spectrum_.reset();
    bands_.reset();
  }

 private:
  void onFrame(std::string_view msg) {
    auto chunk = input_reader_.accept(msg);
    if (!chunk) return;
    if (!spectrum_.hasSubscribers() && !bands_.hasSubscribers()) {
      restart_ = true;  // nobody listens: skip the work, restart the window later
      return;
    }
    chunk->discontinuity = chunk->discontinuity || restart_;
    if (queue_.push(std::move(*chunk))) {
      restart_ = false;
    } else {
      ++dropped_;  // the worker is behind: drop, and restart the window at the next chunk
      restart_ = true;
    }
  }

  // Worker thread: FFT, JSON, then post to the loop thread.
  void work() {
    const std::size_t size = analyser_->options().size;
    while (auto chunk = queue_.pop()) {
      analyser_->feed(*chunk, [&](const skr::audio::Analysis& a) {
        auto spectrum = std::make_shared<std::string>(skr::audio::spectrumJson(a, size));
        auto bands = a.bands ? std::make_shared<std::string>(skr::audio::bandsJson(a)) : nullptr;
        host_.post([this, spectrum, bands] {
          spectrum_.publish(*spectrum);
          if (bands) bands_.publish(*bands);
          ++windows_;
        });
      });
    }
  }

  void writeStats() {
    stats_.publish(host_, input_reader_.counters());
    skr::plugin::dbSet(host_, std::string(host_.name()), "dropped", std::to_string(dropped_));
    skr::plugin::dbSet(host_, std::string(host_.name()), "windows", std::to_string(windows_));
  }

  Host& host_;
  std::string input_;
  std::unique_ptr<skr::audio::SpectrumAnalyser> analyser_;  // the worker's, once started
  skr::audio::BoundedQueue<skr::audio::PcmChunk> queue_;
  skr::audio::PcmInput input_reader_;
  skr::audio::InputStats stats_;
  skr::plugin::StreamChannel spectrum_;
  skr::plugin::StreamChannel bands_;
  skr::plugin::Subscription in_;
  skr::plugin::TickHandle stats_tick_;
  std::thread worker_;
  bool restart_ = false;
  std::uint64_t dropped_ = 0;
  std::uint64_t windows_ = 0;
};

}  // namespace

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    cfg::string("input", nullptr, "the audio channel to analyse, e.g. \"websocket-ui.mic\"")
        .required()
        .nonEmpty(),
    cfg::integer("size", "1024", "samples per window").range(32, 65536),
    cfg::integer("hop", nullptr, "samples between windows, 1..size (default size/2)")
        .range(1, 65536),
    cfg::string("window", "hann", "the window function").oneOf("hann|hamming|blackman|rectangular"),
    cfg::number("bands_rate_hz", "30", "at most this many band messages per second of audio")
        .range(0.01, 1000),
    cfg::number("min_db", "-90", "the dBFS level shown as 0 in the band view").range(-120, -1),
    cfg::integer("queue_max", "64", "frames waiting for the worker; beyond it they are dropped")
        .min(1),
};

SKR_MODULE_WITH_CONFIG(FftAudio, "fft-audio", "1.0.0",
                       "FFTW spectrum and band levels of an audio channel", 0, kConfig)
