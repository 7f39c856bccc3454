// SPDX-License-Identifier: Apache-2.0
// Fuzz target: the agent's rules file (any text; what parses must give a grammar and match
// utterances), a phrase pattern (what parses must match or refuse any utterance, and give a
// JSGF expansion or none), and an utterance against a fixed set of patterns.
#include "number_words.h"
#include "phrase_pattern.h"
#include "rules.h"

#include <cstdint>
#include <string>

using namespace skr::agent;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::vector<std::string> words = wordsOf(text);
  if (auto rules = parseRules(text, "fuzz.json")) {
    (void)rules->grammar();
    (void)rules->match(wordsOf("go forward twenty five meters please"));
    (void)rules->match(words);
  }
  if (auto p = PhrasePattern::parse(text)) {
    (void)p->jsgf();
    (void)p->match(wordsOf("my name is ada and i count to one hundred and five"));
    (void)p->match(words);
  }
  static const PhrasePattern patterns[] = {
      *PhrasePattern::parse("(walk | go) forward [{d:number} (meters | steps)]"),
      *PhrasePattern::parse("my name is {name}"),
      *PhrasePattern::parse("turn {side:word} [now] | stop {what}"),
  };
  for (const PhrasePattern& p : patterns) (void)p.match(words);
  (void)numberFromWords(words);
  return 0;
}
