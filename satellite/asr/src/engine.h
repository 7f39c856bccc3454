// SPDX-License-Identifier: Apache-2.0
// The speech-recognition engine seen by the satellite: one utterance at a time, fed as it is
// heard. pocketsphinx is the one built today (pocketsphinx_engine.h); another engine (whisper.cpp)
// implements the same class and is picked in main.cpp.
//
// Threading: an engine belongs to the recogniser's worker thread (recognizer.h). Every method is
// called from that thread only, never from the satellite's loop; they may block for as long as
// recognition takes. Engines are not copyable.
#pragma once

#include <skrobot/result.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace skr::asr {

// Every engine takes 16 kHz mono signed 16-bit samples (the satellite resamples to it).
inline constexpr std::uint32_t kEngineRateHz = 16000;

enum class Mode { dictation, grammar };
[[nodiscard]] const char* modeName(Mode mode) noexcept;

struct WordTime {
  std::string word;
  double start_s = 0;  // from the first sample fed since start()
  double end_s = 0;
};

struct AsrResult {
  std::string text;       // words separated by one space; empty when nothing was understood
  double confidence = 0;  // 0..1
  bool rejected = false;  // grammar mode: heard, but not a phrase of the grammar
  std::vector<WordTime> words;
  // Grammar mode with rejection: what the decision was made on (engine-specific; for tuning).
  bool scored = false;
  double reject_score = 0;  // the reference's acoustic score per frame minus the grammar's
  double unplaced = 0;      // share of the speech the grammar's words leave out
};

class AsrEngine {
 public:
  virtual ~AsrEngine() = default;
  AsrEngine() = default;
  AsrEngine(const AsrEngine&) = delete;
  AsrEngine& operator=(const AsrEngine&) = delete;
  AsrEngine(AsrEngine&&) = delete;
  AsrEngine& operator=(AsrEngine&&) = delete;

  // A short name for logs and status ("pocketsphinx").
  [[nodiscard]] virtual std::string name() const = 0;

  // Between utterances only. Grammar mode with a JSGF grammar (text), or with a list of
  // keywords/phrases (any one of them is a command). Errc::invalid_argument with the engine's
  // reason when the grammar does not compile; the previous search stays.
  [[nodiscard]] virtual Result<void> setGrammar(const std::string& jsgf) = 0;
  [[nodiscard]] virtual Result<void> setKeywords(const std::vector<std::string>& phrases) = 0;
  [[nodiscard]] virtual Result<void> setDictation() = 0;
  [[nodiscard]] virtual Mode mode() const noexcept = 0;

  // One utterance: start(), feed() any number of times, finish() for the result.
  [[nodiscard]] virtual Result<void> start() = 0;
  [[nodiscard]] virtual Result<void> feed(std::span<const std::int16_t> samples) = 0;
  [[nodiscard]] virtual Result<AsrResult> finish() = 0;
};

}  // namespace skr::asr
