// SPDX-License-Identifier: Apache-2.0
// Mouth shapes for the avatar from the speech module's phoneme timeline (espeak-ng phoneme
// mnemonics, e.g. "h", "@", "l", "'oU", "a:", "_:", "tS"). Fifteen visemes (docs/websocket-ui.md);
// the browser has one morph target per name and blends neighbours (coarticulation) itself.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace skr::wsui {

// Every viseme name visemeFor() returns; the page's morph targets have these names.
inline constexpr std::array<std::string_view, 15> kVisemeNames = {
    "sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "I", "O", "U"};

struct Viseme {
  std::string name;  // one of kVisemeNames
  double open;       // jaw opening 0..1
  double wide;       // lip spread 0..1
  double round;      // lip rounding 0..1
};

// The mouth shape of one phoneme: stress marks (' , % =) are dropped, then the longest known
// prefix of the mnemonic decides ("tS;" -> CH, "a:" -> aa, "@L" -> nn); unknown: "sil".
Viseme visemeFor(std::string_view phoneme);

struct TimedPhoneme {
  std::string phoneme;
  double start_ms = 0;
};
struct TimedViseme {
  double t_ms = 0;
  Viseme viseme;
};

// One viseme per change, merged where the shape does not change, ending with "sil" at
// `duration_ms` (or earlier, at a pause). Input must be in time order (the speech module
// guarantees it).
std::vector<TimedViseme> visemeTimeline(const std::vector<TimedPhoneme>& phonemes,
                                        double duration_ms);

}  // namespace skr::wsui
