// SPDX-License-Identifier: Apache-2.0
#include "player.h"

#include <skrobot/audio/pcm_output.h>

#include <chrono>
#include <memory>

namespace skr::audio {

Player::Player(plugin::Host& host, PlayerOptions options)
    : host_(host), options_(std::move(options)) {}

Player::~Player() {
  stop();
}

void Player::start() {
  const std::string error = reader_.open(options_.file);
  if (!error.empty()) {
    host_.configError("play", error);
    throw plugin::Failure(SKR_ERR_CONFIG, error);
  }
  out_ = plugin::StreamChannel(host_, "playback", pcmMime(),
                               audioProps(reader_.sampleRate(), reader_.channels()),
                               [this](bool first) { setListening(first); });
  plugin::dbSet(host_, std::string(host_.name()), "playing", "false");
  decoder_ = std::thread([this] { work(); });
  host_.log.info("VORBIS-PLAY", "ready to play ", options_.file.string(), " (",
                 reader_.sampleRate(), " Hz, ", reader_.channels(),
                 " channels) when <name>.playback has a subscriber");
}

void Player::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (decoder_.joinable()) decoder_.join();
  out_.reset();
}

void Player::setListening(bool listening) {
  {
    std::lock_guard lock(mutex_);
    listening_ = listening;
  }
  cv_.notify_all();
}

// Decoder thread: waits for a listener, then reads and posts frames no more than lead_ms ahead
// of the wall clock. The clock restarts after each pause.
void Player::work() {
  using Clock = std::chrono::steady_clock;
  PcmWriter writer(reader_.sampleRate(), reader_.channels());
  const std::uint32_t rate = reader_.sampleRate();
  std::vector<std::int16_t> buf;
  Clock::time_point origin;
  std::uint64_t since_origin = 0;  // samples published since origin
  bool paused = true;
  for (;;) {
    {
      std::unique_lock lock(mutex_);
      if (!listening_ && !paused) {
        paused = true;
        host_.post([this] { plugin::dbSet(host_, std::string(host_.name()), "playing", "false"); });
      }
      cv_.wait(lock, [&] { return stopping_ || listening_; });
      if (stopping_) return;
      if (paused) {
        paused = false;
        origin = Clock::now();
        since_origin = 0;
        host_.post([this] { plugin::dbSet(host_, std::string(host_.name()), "playing", "true"); });
      }
      // Pace: frames may run lead_ms ahead of the wall clock since playback (re)started.
      const auto due = origin + std::chrono::milliseconds(options_.lead_ms) +
                       std::chrono::microseconds(since_origin * 1'000'000 / rate);
      if (cv_.wait_until(lock, due, [&] { return stopping_ || !listening_; })) continue;
    }
    buf.clear();
    const long got = reader_.read(buf, options_.frame_samples);
    if (got < 0) {
      host_.log.error("VORBIS-PLAY", "decoding ", options_.file.string(), " failed");
      break;
    }
    if (got == 0) {
      if (options_.loop && reader_.rewind()) continue;
      host_.log.info("VORBIS-PLAY-END", options_.file.string(), ": ", writer.nextSeq(),
                     " samples played");
      break;
    }
    auto frame = std::make_shared<std::string>(writer.frame(buf.data(), buf.size()));
    since_origin += static_cast<std::uint64_t>(got);
    host_.post([this, frame, got] {
      out_.publish(*frame);
      played_ += static_cast<std::uint64_t>(got);
    });
  }
  host_.post([this] {
    const std::string db(host_.name());
    plugin::dbSet(host_, db, "playing", "false");
    plugin::dbSet(host_, db, "played_samples", std::to_string(played_));
  });
}

}  // namespace skr::audio
