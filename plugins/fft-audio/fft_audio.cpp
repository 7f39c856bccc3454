// fft-audio: the spectrum of an audio channel (docs/audio.md).
//   input:  the channel named by config "input" (required), PCM media frames
//   output: <name>.spectrum (JSON per window), <name>.bands (JSON, 16 bands, <= bands_rate_hz/s)
// The loop thread parses frames and counts gaps; a worker thread runs the FFT (one FFTW plan,
// made at init) and posts the JSON back to the loop thread, which publishes it. Nothing is
// analysed while neither output has a subscriber.
#include "bounded_queue.hpp"
#include "input_stats.hpp"
#include "spectrum_analyser.hpp"

#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/json.hpp>

#include <atomic>
#include <memory>
#include <string>
#include <thread>

namespace {

using skr::plugin::Failure;
using skr::plugin::Host;

skr::audio::AnalyserOptions readOptions(Host& host) {
  skr::audio::AnalyserOptions o;
  const std::int64_t size = host.configInt("size", 1024);
  if (size < 32 || size > 65536) {
    host.configError("size", "must be 32..65536 samples, got " + std::to_string(size));
    throw Failure(SKR_ERR_CONFIG, "invalid size");
  }
  o.size = static_cast<std::size_t>(size);
  const std::int64_t hop = host.configInt("hop", size / 2);
  if (hop < 1 || hop > size) {
    host.configError("hop", "must be 1..size, got " + std::to_string(hop));
    throw Failure(SKR_ERR_CONFIG, "invalid hop");
  }
  o.hop = static_cast<std::size_t>(hop);
  const std::string window = host.configString("window", "hann");
  const auto w = skr::audio::windowFromName(window);
  if (!w) {
    host.configError("window",
                     "must be hann, hamming, blackman or rectangular, got '" + window + "'");
    throw Failure(SKR_ERR_CONFIG, "invalid window");
  }
  o.window = *w;
  o.bands_rate_hz = host.configDouble("bands_rate_hz", 30);
  if (!(o.bands_rate_hz > 0 && o.bands_rate_hz <= 1000)) {
    host.configError("bands_rate_hz", "must be > 0 and <= 1000");
    throw Failure(SKR_ERR_CONFIG, "invalid bands_rate_hz");
  }
  o.min_db = host.configDouble("min_db", -90);
  if (!(o.min_db < -1 && o.min_db >= -120)) {
    host.configError("min_db", "must be -120..-1 dBFS");
    throw Failure(SKR_ERR_CONFIG, "invalid min_db");
  }
  return o;
}

class FftAudio final : public skr::plugin::Module {
 public:
  explicit FftAudio(Host& host)
      : host_(host),
        input_(host.configString("input", "")),
        analyser_(std::make_unique<skr::audio::SpectrumAnalyser>(readOptions(host))),
        queue_(
            static_cast<std::size_t>(std::max<std::int64_t>(1, host.configInt("queue_max", 64)))) {
    if (input_.empty()) {
      host.configError("input",
                       "must name the audio channel to analyse, e.g. \"websocket-ui.mic\"");
      throw Failure(SKR_ERR_CONFIG, "invalid input");
    }
  }

  void start() override {
    using namespace skr::plugin;
    const auto& o = analyser_->options();
    Json::Value props(Json::objectValue);
    props["size"] = Json::UInt64(o.size);
    props["hop"] = Json::UInt64(o.hop);
    props["input"] = input_;
    spectrum_ =
        StreamChannel(host_, "spectrum", "application/json", skr::support::writeJson(props));
    bands_ = StreamChannel(host_, "bands", "application/json", R"({"bands":16})");
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

SKROBOT_MODULE(FftAudio, "fft-audio", "1.0.0", "FFTW spectrum and band levels of an audio channel",
               0)
