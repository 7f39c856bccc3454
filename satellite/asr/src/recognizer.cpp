// SPDX-License-Identifier: Apache-2.0
#include "recognizer.h"

#include <chrono>

namespace skr::asr {

Recognizer::Recognizer(std::unique_ptr<AsrEngine> engine, ResultFn on_result,
                       std::size_t max_queued_samples)
    : engine_(std::move(engine)),
      on_result_(std::move(on_result)),
      max_queued_samples_(max_queued_samples),
      worker_([this] { run(); }) {}

Recognizer::~Recognizer() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    queue_.clear();
    queued_samples_ = 0;
  }
  wake_.notify_all();
  worker_.join();
}

void Recognizer::push(Item item) {
  {
    std::lock_guard lock(mutex_);
    if (const auto* a = std::get_if<Audio>(&item)) queued_samples_ += a->samples.size();
    queue_.push_back(std::move(item));
  }
  wake_.notify_one();
}

void Recognizer::begin(const UtteranceBounds&) {
  in_utterance_ = true;
  current_dropped_ = false;
  ++next_utterance_;
  // The mode is read on the worker (a command queued before may change it).
  push(Begin{next_utterance_});
}

void Recognizer::audio(std::span<const std::int16_t> samples) {
  if (!in_utterance_ || current_dropped_) return;
  if (queuedSamples() + samples.size() > max_queued_samples_) {
    current_dropped_ = true;  // the worker is this far behind: give up on this utterance
    return;
  }
  push(Audio{std::vector<std::int16_t>(samples.begin(), samples.end())});
}

void Recognizer::end(const UtteranceBounds& bounds) {
  if (!in_utterance_) return;
  in_utterance_ = false;
  push(End{next_utterance_, bounds, current_dropped_});
}

void Recognizer::command(std::function<void(AsrEngine&)> fn) {
  push(Command{std::move(fn)});
}

bool Recognizer::busy() const {
  std::lock_guard lock(mutex_);
  return working_ || !queue_.empty();
}
std::uint64_t Recognizer::heard() const {
  std::lock_guard lock(mutex_);
  return heard_;
}
std::uint64_t Recognizer::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}
std::size_t Recognizer::queuedSamples() const {
  std::lock_guard lock(mutex_);
  return queued_samples_;
}

void Recognizer::run() {
  bool started = false;  // an engine utterance is open
  bool failed = false;   // this utterance's engine calls failed: report the first error
  Error error;
  Mode mode = Mode::dictation;
  std::vector<std::function<void(AsrEngine&)>> deferred;  // commands that came mid-utterance
  for (;;) {
    Item item;
    {
      std::unique_lock lock(mutex_);
      working_ = false;
      wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      item = std::move(queue_.front());
      queue_.pop_front();
      if (const auto* a = std::get_if<Audio>(&item)) queued_samples_ -= a->samples.size();
      working_ = true;
    }
    if (std::holds_alternative<Begin>(item)) {
      mode = engine_->mode();
      failed = false;
      auto r = engine_->start();
      started = r.ok();
      if (!r) {
        failed = true;
        error = r.error();
      }
    } else if (auto* a = std::get_if<Audio>(&item)) {
      if (started && !failed) {
        auto r = engine_->feed(a->samples);
        if (!r) {
          failed = true;
          error = r.error();
        }
      }
    } else if (auto* e = std::get_if<End>(&item)) {
      Heard heard;
      heard.utterance = e->utterance;
      heard.bounds = e->bounds;
      heard.dropped = e->dropped;
      heard.mode = mode;
      const auto t0 = std::chrono::steady_clock::now();
      if (started) {
        auto r = engine_->finish();  // always, so that the engine is ready for the next one
        if (!failed) heard.result = std::move(r);
      }
      if (failed) heard.result = error;
      heard.engine_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      started = false;
      {
        std::lock_guard lock(mutex_);
        ++heard_;
        if (heard.dropped) ++dropped_;
      }
      on_result_(std::move(heard));
      for (auto& fn : deferred) fn(*engine_);
      deferred.clear();
    } else if (auto* c = std::get_if<Command>(&item)) {
      if (started) {
        deferred.push_back(std::move(c->fn));  // grammars change between utterances only
      } else {
        c->fn(*engine_);
      }
    }
  }
}

}  // namespace skr::asr
