// SPDX-License-Identifier: Apache-2.0
// audio-io: a sound card through PortAudio (docs/audio.md).
//   capture: the input device to <name>.capture (PCM media frames, sample_rate Hz, mono)
//   play:    the audio channel named by config "play" to the output device ("" = off)
// A device thread owns PortAudio (device I/O blocks; the loop thread never does). With no sound
// device the module logs AUDIO-NO-DEVICE, sets "state" to "no-device" in its database and stays
// idle; the hub goes on.
#include <skrobot/audio/input_stats.h>
#include <skrobot/audio/pcm_input.h>
#include <skrobot/audio/pcm_output.h>
#include <skrobot/support/pin_library.hpp>
#include "device_thread.h"
#include "play_buffer.h"

#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>

#include <memory>
#include <optional>

namespace {

// PortAudio (and the JACK it links) stay mapped when the hub unloads this module (pin_library.hpp).
[[maybe_unused]] const bool kPortAudioPinned = skr::support::pinLoadedLibrary("libportaudio.so.2");

using skr::plugin::Host;

class AudioIo final : public skr::plugin::Module {
 public:
  // The host has checked the config against kConfig and filled in the defaults.
  explicit AudioIo(Host& host)
      : host_(host),
        play_channel_(host.configString("play")),
        rate_(host.configInt("sample_rate")),
        frame_(host.configInt("frame_samples")),
        buffer_ms_(host.configInt("max_buffer_ms")),
        writer_(static_cast<std::uint32_t>(rate_), 1) {
    options_.capture = host.configBool("capture");
    options_.input_device = host.configString("input_device");
    options_.play = !play_channel_.empty();
    options_.output_device = host.configString("output_device");
    options_.sample_rate = static_cast<std::uint32_t>(rate_);
    options_.frame_samples = static_cast<std::size_t>(frame_);
    // Room for max_buffer_ms of stereo at 48 kHz, whatever the played channel's format.
    buffer_.emplace(static_cast<std::size_t>(buffer_ms_) * 96);
  }

  void start() override {
    using namespace skr::plugin;
    const std::string db(host_.name());
    dbSet(host_, db, "state", "\"starting\"");
    if (options_.capture) {
      capture_ = StreamChannel(host_, "capture", skr::audio::pcmMime(),
                               skr::audio::audioProps(options_.sample_rate, 1));
    }
    skr::audio::DeviceEvents events;
    events.captured = [this](std::vector<std::int16_t> samples, std::int64_t capture_ns) {
      auto shared = std::make_shared<std::vector<std::int16_t>>(std::move(samples));
      host_.post([this, shared, capture_ns] {
        capture_.publish(writer_.frame(shared->data(), shared->size(), capture_ns));
      });
    };
    events.status = [this, db](const std::string& key, const std::string& value) {
      host_.post([this, db, key, value] { dbSet(host_, db, key, value); });
    };
    device_.emplace(host_, options_, *buffer_, std::move(events));
    device_->start();
    if (options_.play) {
      play_ = Subscription(host_, play_channel_, [this](std::string_view msg) {
        if (auto c = input_.accept(msg)) {
          buffer_->push(c->samples, c->sample_rate, c->channels);
          device_->wake();
        }
      });
      stats_tick_ = host_.onTick(Tick::one_sec, [this] { writeStats(); });
    }
  }

  void stop() override {
    play_.reset();
    if (device_) device_->stop();
    stats_tick_.reset();
    capture_.reset();
  }

 private:
  void writeStats() {
    stats_.publish(host_, input_.counters(), "play_");
    skr::plugin::dbSet(host_, std::string(host_.name()), "play_dropped",
                       std::to_string(buffer_->dropped()));
  }

  Host& host_;
  std::string play_channel_;
  std::int64_t rate_;
  std::int64_t frame_;
  std::int64_t buffer_ms_;
  skr::audio::DeviceOptions options_;
  skr::audio::PcmWriter writer_;
  std::optional<skr::audio::PlayBuffer> buffer_;
  skr::audio::PcmInput input_;
  skr::audio::InputStats stats_;
  skr::plugin::StreamChannel capture_;
  skr::plugin::Subscription play_;
  skr::plugin::TickHandle stats_tick_;
  std::optional<skr::audio::DeviceThread> device_;
};

}  // namespace

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    cfg::boolean("capture", "true", "capture from the input device to <name>.capture"),
    cfg::string("input_device", "", "\"\": the default input; else a part of a device name"),
    cfg::integer("sample_rate", "22050", "capture rate in Hz").range(8000, 192000),
    cfg::integer("frame_samples", "1024", "samples per captured frame").range(32, 65536),
    cfg::string("play", "", "an audio channel to play on the output device; \"\": no playback"),
    cfg::string("output_device", "", "\"\": the default output; else a part of a device name"),
    cfg::integer("max_buffer_ms", "2000", "playback buffer; when full the oldest samples go")
        .range(100, 60000),
};

SKR_MODULE_WITH_CONFIG(AudioIo, "audio-io", "1.0.0", "sound card capture and playback (PortAudio)",
                       0, kConfig)
