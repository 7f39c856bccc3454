// SPDX-License-Identifier: Apache-2.0
// The recogniser's worker thread: it owns the engine and runs every engine call, so that
// recognition never runs on the satellite's loop. The loop thread hands it utterances as they are
// heard (begin, audio, end) and engine commands (a grammar, a mode); results come back through
// the callbacks, called on the worker thread (the satellite posts them to its loop).
//
// The queue is bounded by `max_queued_samples`: when the worker falls that far behind, the
// utterance being queued is dropped (its audio is no longer queued, its end reports
// `dropped`), so memory stays bounded whatever the input.
#pragma once

#include "engine.h"
#include "segmenter.h"

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <variant>
#include <vector>

namespace skr::asr {

struct Heard {
  std::uint64_t utterance = 0;  // numbered from 1
  UtteranceBounds bounds;
  Result<AsrResult> result = AsrResult{};
  bool dropped = false;         // the worker was too far behind: not recognised
  double engine_ms = 0;         // worker time spent in finish()
  Mode mode = Mode::dictation;  // the engine's mode for this utterance
};

class Recognizer {
 public:
  using ResultFn = std::function<void(Heard)>;  // called on the worker thread

  Recognizer(std::unique_ptr<AsrEngine> engine, ResultFn on_result,
             std::size_t max_queued_samples = 30 * kEngineRateHz);
  ~Recognizer();  // drops queued work and joins the worker (after the engine call in progress)
  Recognizer(const Recognizer&) = delete;
  Recognizer& operator=(const Recognizer&) = delete;
  Recognizer(Recognizer&&) = delete;
  Recognizer& operator=(Recognizer&&) = delete;

  // Loop thread. An utterance: begin, audio in order, end (see Segmenter).
  void begin(const UtteranceBounds& bounds);
  void audio(std::span<const std::int16_t> samples);
  void end(const UtteranceBounds& bounds);
  // Loop thread. Runs `fn` on the worker between utterances, in queue order.
  void command(std::function<void(AsrEngine&)> fn);

  // Any thread.
  [[nodiscard]] bool busy() const;  // recognising, or work queued
  [[nodiscard]] std::uint64_t heard() const;
  // Loop thread: the number of the utterance begun last (0: none yet).
  [[nodiscard]] std::uint64_t lastBegun() const noexcept { return next_utterance_; }
  [[nodiscard]] std::uint64_t dropped() const;
  [[nodiscard]] std::size_t queuedSamples() const;

 private:
  struct Begin {
    std::uint64_t utterance;
  };
  struct Audio {
    std::vector<std::int16_t> samples;
  };
  struct End {
    std::uint64_t utterance;
    UtteranceBounds bounds;
    bool dropped;
  };
  struct Command {
    std::function<void(AsrEngine&)> fn;
  };
  using Item = std::variant<Begin, Audio, End, Command>;

  void push(Item item);
  void run();

  std::unique_ptr<AsrEngine> engine_;
  ResultFn on_result_;
  std::size_t max_queued_samples_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Item> queue_;
  std::size_t queued_samples_ = 0;
  bool stopping_ = false;
  bool working_ = false;
  std::uint64_t heard_ = 0, dropped_ = 0;

  // Loop thread only.
  std::uint64_t next_utterance_ = 0;
  bool current_dropped_ = false;
  bool in_utterance_ = false;

  std::thread worker_;
};

}  // namespace skr::asr
