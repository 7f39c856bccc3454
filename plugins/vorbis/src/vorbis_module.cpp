// SPDX-License-Identifier: Apache-2.0
// vorbis: record an audio channel to Ogg Vorbis files, and play an .ogg file onto
// <name>.playback (docs/audio.md). Either part is off when its config key is empty.
#include "player.h"
#include "recorder.h"

#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>

#include <memory>
#include <optional>

namespace {

using skr::plugin::Failure;
using skr::plugin::Host;

[[noreturn]] void bad(Host& host, const char* key, const std::string& why) {
  host.configError(key, why);
  throw Failure(SKR_ERR_CONFIG, std::string("invalid ") + key);
}

class Vorbis final : public skr::plugin::Module {
 public:
  // The host has checked the config against kConfig and filled in the defaults; a prefix with
  // a '/' is what the declaration cannot refuse.
  explicit Vorbis(Host& host) : host_(host) {
    if (const std::string channel = host.configString("record"); !channel.empty()) {
      skr::audio::RecorderOptions o;
      o.channel = channel;
      o.dir = host.configString("dir");
      o.prefix = host.configString("prefix", std::string(host.name()));
      if (o.prefix.empty() || o.prefix.find('/') != std::string::npos) {
        bad(host, "prefix", "must be a file name prefix without '/'");
      }
      o.rotate_bytes = static_cast<std::uint64_t>(host.configInt("rotate_kb")) * 1024;
      o.rotate_seconds = static_cast<std::uint64_t>(host.configInt("rotate_s"));
      o.quality = static_cast<float>(host.configDouble("quality"));
      o.queue_max = static_cast<std::size_t>(host.configInt("queue_max"));
      recorder_.emplace(host, std::move(o));
    }
    if (const std::string file = host.configString("play"); !file.empty()) {
      skr::audio::PlayerOptions o;
      o.file = file;
      o.loop = host.configBool("loop");
      o.lead_ms = host.configInt("lead_ms");
      o.frame_samples = static_cast<std::size_t>(host.configInt("frame_samples"));
      player_.emplace(host, std::move(o));
    }
    if (!recorder_ && !player_) {
      host.log.warn("VORBIS-IDLE", "neither \"record\" nor \"play\" is set: nothing to do");
    }
  }

  void start() override {
    if (player_) player_->start();
    if (recorder_) {
      recorder_->start();
      stats_ = host_.onTick(skr::plugin::Tick::one_sec, [this] { recorder_->writeStats(); });
    }
  }

  void stop() override {
    stats_.reset();
    if (recorder_) recorder_->stop();
    if (player_) player_->stop();
  }

 private:
  Host& host_;
  std::optional<skr::audio::Recorder> recorder_;
  std::optional<skr::audio::Player> player_;
  skr::plugin::TickHandle stats_;
};

}  // namespace

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    // Recording (on when "record" is set).
    cfg::string("record", "", "the audio channel to record; \"\": no recording"),
    cfg::string("dir", "recordings", "directory of the recordings (created)").nonEmpty(),
    cfg::string("prefix", nullptr, "file name prefix, without '/' (default: the module's name)"),
    cfg::integer("rotate_kb", "10240", "start a new file once a file reaches this size; 0: never")
        .min(0),
    cfg::integer("rotate_s", "600", "seconds of audio per file at most; 0: no limit").min(0),
    cfg::number("quality", "0.4", "libvorbis VBR quality").range(-0.1, 1.0),
    cfg::integer("queue_max", "256", "frames waiting for the writer; beyond it they are dropped")
        .min(1),
    // Playing (on when "play" is set).
    cfg::string("play", "", "an .ogg file to play onto <name>.playback; \"\": none"),
    cfg::boolean("loop", "false", "start again at the end of the file"),
    cfg::integer("lead_ms", "300", "how far ahead of real time frames are published")
        .range(0, 60000),
    cfg::integer("frame_samples", "1024", "samples (per channel) per played frame")
        .range(64, 65536),
};

SKR_MODULE_WITH_CONFIG(Vorbis, "vorbis", "1.0.0",
                       "records audio channels to Ogg Vorbis and plays .ogg files", 0, kConfig)
