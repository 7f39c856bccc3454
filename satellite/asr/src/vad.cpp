// SPDX-License-Identifier: Apache-2.0
#include "vad.h"

#include <algorithm>
#include <cmath>

namespace skr::asr {

Vad::Vad(VadOptions options) : options_(options), floor_db_(options.initial_floor_db) {}

void Vad::reset() noexcept {
  floor_db_ = options_.initial_floor_db;
  level_db_ = -120;
  dc_x_ = dc_y_ = 0;
  in_speech_ = false;
  seen_audio_ = false;
  voiced_run_ = unvoiced_run_ = 0;
  frame_ = start_ = end_ = 0;
}

void Vad::forceEnd() noexcept {
  if (!in_speech_) return;
  in_speech_ = false;
  end_ = frame_;
  voiced_run_ = unvoiced_run_ = 0;
}

Vad::Event Vad::push(std::span<const std::int16_t> frame) {
  // DC blocker (one pole at ~20 Hz), then the frame's RMS.
  double energy = 0;
  for (const auto s : frame) {
    const double x = s / 32768.0;
    const double y = x - dc_x_ + 0.992 * dc_y_;
    dc_x_ = x;
    dc_y_ = y;
    energy += y * y;
  }
  energy /= std::max<std::size_t>(frame.size(), 1);
  level_db_ = 10 * std::log10(energy + 1e-12);
  const double frame_s = static_cast<double>(kVadFrameSamples) / 16000;

  if (!seen_audio_) {
    // The first frame is the best guess of the background: a stream that starts with speech
    // has its floor corrected at the first pause (the floor falls at once).
    floor_db_ = std::max(level_db_, -100.0);
    seen_audio_ = true;
  }
  const bool voiced =
      level_db_ > floor_db_ + options_.threshold_db && level_db_ > options_.min_level_db;
  if (level_db_ < floor_db_) {
    floor_db_ = std::max(level_db_, -100.0);
  } else {
    floor_db_ = std::min(floor_db_ + options_.floor_rise_db_per_s * frame_s, level_db_);
  }

  const std::uint64_t index = frame_++;
  const int attack_frames = std::max(1, options_.attack_ms / 10);
  const int hangover_frames = std::max(1, options_.hangover_ms / 10);
  if (!in_speech_) {
    voiced_run_ = voiced ? voiced_run_ + 1 : 0;
    if (voiced_run_ >= attack_frames) {
      in_speech_ = true;
      start_ = index + 1 - static_cast<std::uint64_t>(voiced_run_);
      unvoiced_run_ = 0;
      return Event::started;
    }
    return Event::none;
  }
  if (voiced) {
    unvoiced_run_ = 0;
    return Event::none;
  }
  if (++unvoiced_run_ >= hangover_frames) {
    in_speech_ = false;
    end_ = index + 1 - static_cast<std::uint64_t>(unvoiced_run_);
    voiced_run_ = unvoiced_run_ = 0;
    return Event::ended;
  }
  return Event::none;
}

}  // namespace skr::asr
