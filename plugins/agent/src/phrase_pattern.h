// SPDX-License-Identifier: Apache-2.0
// The agent's phrase patterns: what an intent matches in a transcript, with slots.
//
//   "(walk | go) forward [{distance:number} (meters | steps)]"
//   "my name is {name}"
//
// Words match words (lower case; transcripts are lowered and stripped of punctuation);
// (a | b c) is one of the alternatives, [x y] is optional (both nest); {name} is a slot of one to
// eight words, {name:word} exactly one, {name:number} a number in digits or words ("twenty
// five"). A pattern matches a whole utterance; one that would take more than 100 000 matching
// steps (many slots over a long utterance) does not match.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <skrobot/result.hpp>

namespace skr::agent {

struct SlotValue {
  std::string text;              // the words it took, space-separated
  std::optional<double> number;  // for {name:number}
};
using Slots = std::map<std::string, SlotValue>;

// Lower case words of a transcript: letters, digits, apostrophes and '.' inside numbers kept.
[[nodiscard]] std::vector<std::string> wordsOf(const std::string& text);

class PhrasePattern {
 public:
  // Errc::invalid_argument naming the column and the reason ("unbalanced '('").
  static Result<PhrasePattern> parse(const std::string& text);

  // The slots when the whole of `words` matches.
  [[nodiscard]] std::optional<Slots> match(const std::vector<std::string>& words) const;
  // The pattern as a JSGF expansion (number slots as <number>); nullopt when it has a free or
  // word slot, which a grammar cannot list.
  [[nodiscard]] std::optional<std::string> jsgf() const;
  // How specific a match is: literal words count, so "stop walking" beats "stop {what}".
  [[nodiscard]] int literalWords() const noexcept { return literal_words_; }
  [[nodiscard]] const std::string& text() const noexcept { return text_; }

  struct Node;

 private:
  std::string text_;
  std::shared_ptr<const Node> root_;  // a sequence
  int literal_words_ = 0;
};

}  // namespace skr::agent
