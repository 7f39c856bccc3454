// SPDX-License-Identifier: Apache-2.0
// AsrEngine on pocketsphinx (Debian's 0.8+5prealpha: cmd_ln_init, ps_init, ps_process_raw).
//
// Dictation uses the model's language model. Grammar mode uses a JSGF search (a keyword list is
// turned into a one-rule grammar) and, to reject speech that is not in the grammar, a second
// decoder running the language model's first pass over the same audio (what the audio sounds like
// when the grammar does not constrain it). An utterance is rejected when either
//  - the free decoder's acoustic score per frame beats the grammar's by more than
//    `reject_threshold`, or
//  - more than `max_unplaced` of the frames the free decoder hears as words fall in silence or
//    fillers on the grammar's path: out-of-grammar speech mostly ends up there, with one short
//    phrase of the grammar beside it.
// (A phone loop, the classic reference, ran 10 times slower than real time in 5prealpha: not
// usable.) `reject = false` turns rejection off, and the second decoder with it.
#pragma once

#include "engine.h"

#include <memory>
#include <string>
#include <vector>

namespace skr::asr {

struct PocketsphinxOptions {
  std::string model_dir = "/usr/share/pocketsphinx/model/en-us";  // en-us/, en-us.lm.bin, *.dict
  bool reject = true;
  double reject_threshold = 5;  // acoustic score per frame
  double max_unplaced = 0.4;    // share of the reference's speech frames the grammar leaves out
};

class PocketsphinxEngine final : public AsrEngine {
 public:
  // Loads the models (about half a second). Errc::not_found / config_error with the reason.
  [[nodiscard]] static Result<std::unique_ptr<PocketsphinxEngine>> create(
      const PocketsphinxOptions& options);
  ~PocketsphinxEngine() override;

  [[nodiscard]] std::string name() const override { return "pocketsphinx"; }
  [[nodiscard]] Result<void> setGrammar(const std::string& jsgf) override;
  [[nodiscard]] Result<void> setKeywords(const std::vector<std::string>& phrases) override;
  [[nodiscard]] Result<void> setDictation() override;
  [[nodiscard]] Mode mode() const noexcept override { return mode_; }
  [[nodiscard]] Result<void> start() override;
  [[nodiscard]] Result<void> feed(std::span<const std::int16_t> samples) override;
  [[nodiscard]] Result<AsrResult> finish() override;

 private:
  struct Decoder;
  explicit PocketsphinxEngine(PocketsphinxOptions options);

  PocketsphinxOptions options_;
  std::unique_ptr<Decoder> main_;   // dictation and grammar searches
  std::unique_ptr<Decoder> phone_;  // the reference (grammar mode with rejection only)
  Mode mode_ = Mode::dictation;
  std::string dictation_search_ = "_default";
  int grammar_serial_ = 0;
  bool phone_active_ = false;
};

}  // namespace skr::asr
