// SPDX-License-Identifier: Apache-2.0
#include "segmenter.h"

#include <algorithm>

namespace skr::asr {

Segmenter::Segmenter(SegmenterOptions options, SegmenterSink sink)
    : options_(options), sink_(std::move(sink)), vad_(options.vad) {
  partial_.reserve(kVadFrameSamples);
}

void Segmenter::push(std::span<const std::int16_t> samples) {
  while (!samples.empty()) {
    const std::size_t take = std::min(samples.size(), kVadFrameSamples - partial_.size());
    partial_.insert(partial_.end(), samples.begin(), samples.begin() + take);
    samples = samples.subspan(take);
    if (partial_.size() == kVadFrameSamples) {
      frame(partial_);
      partial_.clear();
    }
  }
}

void Segmenter::flush() {
  if (in_utterance_) endUtterance(position_, false);
  vad_.forceEnd();
}

void Segmenter::frame(std::span<const std::int16_t> f) {
  position_ += f.size();
  const std::size_t ring_max =
      static_cast<std::size_t>(options_.preroll_ms + options_.vad.attack_ms + 10) * 16;
  ring_.insert(ring_.end(), f.begin(), f.end());
  while (ring_.size() > ring_max) {
    ring_.pop_front();
    ++ring_start_;
  }

  const Vad::Event event = vad_.push(f);
  const auto frameSample = [&](std::uint64_t vad_frame) {
    return vad_base_ + vad_frame * kVadFrameSamples;
  };
  if (!in_utterance_) {
    if (event != Vad::Event::started) return;
    in_utterance_ = true;
    current_ = {};
    current_.speech_start = frameSample(vad_.speechStart());
    const std::uint64_t preroll = static_cast<std::uint64_t>(options_.preroll_ms) * 16;
    current_.audio_start =
        std::max(ring_start_, current_.speech_start > preroll ? current_.speech_start - preroll
                                                              : std::uint64_t{0});
    fed_ = 0;
    if (sink_.start) sink_.start(current_);
    // The ring holds everything from audio_start to the end of this frame.
    std::vector<std::int16_t> head(
        ring_.begin() + static_cast<std::ptrdiff_t>(current_.audio_start - ring_start_),
        ring_.end());
    fed_ += head.size();
    if (sink_.audio) sink_.audio(head);
  } else {
    fed_ += f.size();
    if (sink_.audio) sink_.audio(f);
    if (event == Vad::Event::ended) {
      endUtterance(frameSample(vad_.speechEnd()), false);
      return;
    }
  }
  const auto max_samples = static_cast<std::uint64_t>(options_.max_utterance_s * 16000);
  if (in_utterance_ && fed_ >= max_samples) {
    vad_.forceEnd();
    endUtterance(position_, true);
  }
}

void Segmenter::endUtterance(std::uint64_t speech_end, bool cut) {
  in_utterance_ = false;
  current_.speech_end = std::max(speech_end, current_.speech_start);
  current_.decided_at = position_;
  current_.cut = cut;
  if (sink_.end) sink_.end(current_);
}

}  // namespace skr::asr
