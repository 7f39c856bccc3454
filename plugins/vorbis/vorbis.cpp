// vorbis: record an audio channel to Ogg Vorbis files, and play an .ogg file onto
// <name>.playback (docs/audio.md). Either part is off when its config key is empty.
#include "player.hpp"
#include "recorder.hpp"

#include <skrobot/plugin_channels.hpp>

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
  explicit Vorbis(Host& host) : host_(host) {
    if (const std::string channel = host.configString("record", ""); !channel.empty()) {
      skr::audio::RecorderOptions o;
      o.channel = channel;
      o.dir = host.configString("dir", "recordings");
      o.prefix = host.configString("prefix", std::string(host.name()));
      const std::int64_t kb = host.configInt("rotate_kb", 10240);
      const std::int64_t s = host.configInt("rotate_s", 600);
      const double q = host.configDouble("quality", 0.4);
      const std::int64_t queue = host.configInt("queue_max", 256);
      if (o.dir.empty()) bad(host, "dir", "must be a directory");
      if (o.prefix.empty() || o.prefix.find('/') != std::string::npos) {
        bad(host, "prefix", "must be a file name prefix without '/'");
      }
      if (kb < 0) bad(host, "rotate_kb", "must be >= 0 (0: no rotation by size)");
      if (s < 0) bad(host, "rotate_s", "must be >= 0 (0: no rotation by duration)");
      if (!(q >= -0.1 && q <= 1.0)) bad(host, "quality", "must be -0.1..1.0");
      if (queue < 1) bad(host, "queue_max", "must be >= 1");
      o.rotate_bytes = static_cast<std::uint64_t>(kb) * 1024;
      o.rotate_seconds = static_cast<std::uint64_t>(s);
      o.quality = static_cast<float>(q);
      o.queue_max = static_cast<std::size_t>(queue);
      recorder_.emplace(host, std::move(o));
    }
    if (const std::string file = host.configString("play", ""); !file.empty()) {
      skr::audio::PlayerOptions o;
      o.file = file;
      o.loop = host.configBool("loop", false);
      o.lead_ms = host.configInt("lead_ms", 300);
      const std::int64_t frame = host.configInt("frame_samples", 1024);
      if (o.lead_ms < 0 || o.lead_ms > 60000) bad(host, "lead_ms", "must be 0..60000");
      if (frame < 64 || frame > 65536) bad(host, "frame_samples", "must be 64..65536");
      o.frame_samples = static_cast<std::size_t>(frame);
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

SKROBOT_MODULE(Vorbis, "vorbis", "1.0.0",
               "records audio channels to Ogg Vorbis and plays .ogg files", 0)
