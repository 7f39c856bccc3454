// SPDX-License-Identifier: Apache-2.0
// Cuts a continuous 16 kHz stream into utterances with the VAD (vad.h): each utterance is the
// speech with `preroll_ms` of audio before it (the recogniser needs the onset) and the VAD's
// hang-over after it. An utterance that reaches `max_utterance_s` is ended there, marked cut, and
// the next one starts at once if speech goes on. Memory is bounded by the pre-roll ring: audio is
// handed on as it arrives, never accumulated here.
//
// Sample indices count 16 kHz samples pushed since construction (or reset()). Single-threaded.
#pragma once

#include "vad.h"

#include <cstdint>
#include <deque>
#include <functional>
#include <span>
#include <vector>

namespace skr::asr {

struct SegmenterOptions {
  VadOptions vad;
  int preroll_ms = 200;
  double max_utterance_s = 15;
};

struct UtteranceBounds {
  std::uint64_t audio_start = 0;   // the first sample handed on (speech start minus pre-roll)
  std::uint64_t speech_start = 0;  // as the VAD decided
  std::uint64_t speech_end = 0;    // the sample after the last voiced one (or the cut)
  std::uint64_t decided_at = 0;    // where the stream was when the end was decided
  bool cut = false;                // ended at max_utterance_s
};

struct SegmenterSink {
  std::function<void(const UtteranceBounds&)> start;         // speech_start, audio_start set
  std::function<void(std::span<const std::int16_t>)> audio;  // the utterance's samples, in order
  std::function<void(const UtteranceBounds&)> end;           // all fields set
};

class Segmenter {
 public:
  Segmenter(SegmenterOptions options, SegmenterSink sink);

  void push(std::span<const std::int16_t> samples);
  // Ends the utterance in progress, if any (not cut): before a gap, a pause, or a format change.
  void flush();

  [[nodiscard]] bool inUtterance() const noexcept { return in_utterance_; }
  [[nodiscard]] std::uint64_t position() const noexcept { return position_; }
  [[nodiscard]] const Vad& vad() const noexcept { return vad_; }
  [[nodiscard]] const SegmenterOptions& options() const noexcept { return options_; }

 private:
  void frame(std::span<const std::int16_t> f);
  void endUtterance(std::uint64_t speech_end, bool cut);

  SegmenterOptions options_;
  SegmenterSink sink_;
  Vad vad_;
  std::vector<std::int16_t> partial_;  // less than a frame
  std::deque<std::int16_t> ring_;      // the last pre-roll + attack of audio
  std::uint64_t ring_start_ = 0;       // sample index of ring_.front()
  std::uint64_t position_ = 0;         // samples taken into frames
  std::uint64_t vad_base_ = 0;         // sample index of the VAD's frame 0
  bool in_utterance_ = false;
  UtteranceBounds current_;
  std::uint64_t fed_ = 0;  // samples of the current utterance handed on
};

}  // namespace skr::asr
