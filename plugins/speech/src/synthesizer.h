// SPDX-License-Identifier: Apache-2.0
// espeak-ng in synchronous mode, with phoneme and word events. espeak-ng keeps global state:
// at most one Synthesizer exists in the process at a time (a second one reports an error), and
// all calls on it come from one thread. The library is initialised by the first Synthesizer and
// stays so until the process exits (see synthesizer.cpp).
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

namespace skr::speech {

struct Phoneme {
  std::string ph;    // espeak-ng phoneme mnemonic, e.g. "h", "@U"
  int start_ms = 0;  // from the start of the utterance
};

struct Word {
  int start_ms = 0;
  std::string text;  // the word as written in the request
};

struct Utterance {
  std::vector<std::int16_t> samples;  // mono, sampleRate() Hz
  std::vector<Phoneme> phonemes;      // strictly increasing start_ms, all < durationMs()
  std::vector<Word> words;
  std::uint32_t sample_rate = 0;
  [[nodiscard]] int durationMs() const noexcept {
    return sample_rate == 0 ? 0 : static_cast<int>(samples.size() * 1000 / sample_rate);
  }
};

struct Voice {
  std::string name;    // any espeak-ng voice name or language, e.g. "en", "it", "en-us"
  int rate_wpm = 175;  // 80..450
  int pitch = 50;      // 0..100
};

class Synthesizer {
 public:
  // Initialises espeak-ng (data from its default path). Check ok() / error() afterwards.
  Synthesizer();
  ~Synthesizer();
  Synthesizer(const Synthesizer&) = delete;
  Synthesizer& operator=(const Synthesizer&) = delete;
  Synthesizer(Synthesizer&&) = delete;
  Synthesizer& operator=(Synthesizer&&) = delete;

  [[nodiscard]] bool ok() const noexcept { return sample_rate_ > 0; }
  [[nodiscard]] const std::string& error() const noexcept { return error_; }
  [[nodiscard]] std::uint32_t sampleRate() const noexcept { return sample_rate_; }

  // Synthesizes `text` (UTF-8) completely; an error text for an unknown voice or a failure.
  std::variant<Utterance, std::string> say(const std::string& text, const Voice& voice);

 private:
  std::uint32_t sample_rate_ = 0;
  bool owner_ = false;
  std::string current_voice_;  // the voice espeak-ng has loaded  // this instance holds the
                               // process-wide espeak-ng
  std::string error_;
};

}  // namespace skr::speech
