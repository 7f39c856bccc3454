// SPDX-License-Identifier: Apache-2.0
// Mouth shapes for the avatar from the speech module's phoneme timeline (espeak-ng phoneme
// mnemonics, e.g. "h", "@", "l", "oU", "a:", "_:"). Five shapes and rest are enough for a
// stylised head: the browser turns each into jaw/wide/round morph weights.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace skr::wsui {

struct Viseme {
  std::string name;  // "rest", "AA", "EE", "OO", "MBP", "FV", "CH"
  double open;       // jaw opening 0..1
  double wide;       // lip spread 0..1
  double round;      // lip rounding 0..1
};

// The mouth shape of one phoneme.
Viseme visemeFor(std::string_view phoneme);

struct TimedPhoneme {
  std::string phoneme;
  double start_ms = 0;
};
struct TimedViseme {
  double t_ms = 0;
  Viseme viseme;
};

// One viseme per phoneme, merged where the shape does not change, ending with "rest" at
// `duration_ms`. Input must be in time order (the speech module guarantees it).
std::vector<TimedViseme> visemeTimeline(const std::vector<TimedPhoneme>& phonemes,
                                        double duration_ms);

}  // namespace skr::wsui
