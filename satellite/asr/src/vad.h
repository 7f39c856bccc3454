// SPDX-License-Identifier: Apache-2.0
// Voice-activity detection by energy over an adaptive noise floor, in 10 ms frames of 16 kHz
// audio.
//
// Each frame's level (dBFS, after a DC-blocking high-pass) is compared with the noise floor: a
// frame is voiced when it is `threshold_db` above the floor and above `min_level_db` (so digital
// silence and faint hiss never count). The floor follows the level down at once and up slowly
// (`floor_rise_db_per_s`), so a steady noise becomes the floor within seconds while speech, with
// its pauses between words, does not. Speech starts after `attack_ms` of voiced frames (the start
// is the first of them) and ends after `hangover_ms` of unvoiced ones (the end is the last voiced
// frame). Single-threaded, no allocation.
#pragma once

#include <cstdint>
#include <span>

namespace skr::asr {

struct VadOptions {
  double threshold_db = 12;        // voiced: this far above the noise floor
  double min_level_db = -55;       // and at least this loud (dBFS)
  double floor_rise_db_per_s = 2;  // how fast the floor climbs towards a louder background
  double initial_floor_db = -70;   // the floor before any audio
  int attack_ms = 40;              // voiced time before speech is declared started
  int hangover_ms = 300;           // unvoiced time before speech is declared ended
};

inline constexpr int kVadFrameSamples = 160;  // 10 ms at 16 kHz

class Vad {
 public:
  enum class Event { none, started, ended };

  explicit Vad(VadOptions options = {});

  // One frame of kVadFrameSamples. On `started`, speechStart() is the frame index where speech
  // began (attack frames back); on `ended`, speechEnd() is the frame after the last voiced one.
  Event push(std::span<const std::int16_t> frame);
  // Ends speech now if it is going on (a cut, a gap): no event.
  void forceEnd() noexcept;
  void reset() noexcept;

  [[nodiscard]] bool inSpeech() const noexcept { return in_speech_; }
  [[nodiscard]] std::uint64_t frames() const noexcept { return frame_; }  // frames pushed
  [[nodiscard]] std::uint64_t speechStart() const noexcept { return start_; }
  [[nodiscard]] std::uint64_t speechEnd() const noexcept { return end_; }
  [[nodiscard]] double levelDb() const noexcept { return level_db_; }  // the last frame's
  [[nodiscard]] double floorDb() const noexcept { return floor_db_; }
  [[nodiscard]] const VadOptions& options() const noexcept { return options_; }

 private:
  VadOptions options_;
  double floor_db_;
  double level_db_ = -120;
  double dc_x_ = 0, dc_y_ = 0;  // DC blocker state
  bool in_speech_ = false;
  bool seen_audio_ = false;
  int voiced_run_ = 0, unvoiced_run_ = 0;
  std::uint64_t frame_ = 0, start_ = 0, end_ = 0;
};

}  // namespace skr::asr
