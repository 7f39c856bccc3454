// SPDX-License-Identifier: Apache-2.0
#include "visemes.h"

#include <algorithm>
#include <cstddef>
#include <utility>

namespace skr::wsui {
namespace {

// Indices into kVisemeNames.
enum V : std::size_t { sil, PP, FF, TH, DD, kk, CH, SS, nn, RR, aa, E, I, O, U };

struct Shape {
  double open, wide, round;
};
// In the order of kVisemeNames.
constexpr std::array<Shape, kVisemeNames.size()> kShapes = {{
    {0.0, 0.0, 0.0},     // sil
    {0.0, 0.1, 0.05},    // PP: lips pressed
    {0.1, 0.25, 0.0},    // FF: lower lip to the teeth
    {0.2, 0.3, 0.0},     // TH: tongue between the teeth
    {0.25, 0.3, 0.0},    // DD
    {0.35, 0.25, 0.0},   // kk
    {0.25, 0.05, 0.55},  // CH: lips pushed forward
    {0.15, 0.5, 0.0},    // SS: teeth close, lips spread
    {0.25, 0.3, 0.0},    // nn
    {0.25, 0.1, 0.45},   // RR
    {0.8, 0.35, 0.0},    // aa
    {0.5, 0.5, 0.0},     // E
    {0.3, 0.7, 0.0},     // I
    {0.6, 0.1, 0.6},     // O
    {0.3, 0.0, 0.85},    // U
}};

// espeak-ng mnemonics by viseme, separated by spaces (case matters: "S" is sh, "s" is s). A
// mnemonic stands for every longer one that starts with it unless that one is listed too: "t"
// covers "t#", "a" covers "a:" and "aI", but "tS" is CH and "@L" is nn.
constexpr std::pair<V, std::string_view> kPhonemes[] = {
    {sil, "_"},             // pauses: _ _: _! _^_
    {PP, "p b m"},          // lips pressed
    {FF, "f v"},            // lower lip on the teeth
    {TH, "T D"},            // th: tongue between the teeth
    {DD, "t d"},            // t# d# (flaps) too
    {kk, "k g N h x c C"},  // N: ng; h, x and palatals too
    {CH, "tS dZ S Z"},      // ch, j, sh, zh: lips pushed forward
    {SS, "s z"},            // teeth close, lips spread
    {nn, "n l L J @L n-"},  // syllabic @L and n- too
    {RR, "r R"},            // r- (linking r) too
    {aa, "a A V &"},        // a: a# A: A@ aI aU
    {E, "e E @ 3"},         // e@ eI @2 3:
    {I, "i I j"},           // i: i@ I2
    {O, "o O 0 Q W"},       // O: O@ OI oU, British 0 (lot)
    {U, "u U w y Y"},       // u: U@, rounded front y
};

Viseme shape(V v) {
  const Shape& s = kShapes[v];
  return {std::string(kVisemeNames[v]), s.open, s.wide, s.round};
}

}  // namespace

Viseme visemeFor(std::string_view ph) {
  while (!ph.empty() &&
         (ph.front() == '\'' || ph.front() == ',' || ph.front() == '%' || ph.front() == '=')) {
    ph.remove_prefix(1);  // stress marks
  }
  // The longest listed mnemonic that it starts with: "tS;" is CH, "a:" and "aI" are aa.
  V best = sil;
  std::size_t best_size = 0;
  for (const auto& [v, list] : kPhonemes) {
    for (std::size_t at = 0; at < list.size();) {
      const std::size_t space = std::min(list.find(' ', at), list.size());
      const std::string_view mnemonic = list.substr(at, space - at);
      if (mnemonic.size() > best_size && ph.starts_with(mnemonic)) {
        best = v;
        best_size = mnemonic.size();
      }
      at = space + 1;
    }
  }
  return shape(best);
}

std::vector<TimedViseme> visemeTimeline(const std::vector<TimedPhoneme>& phonemes,
                                        double duration_ms) {
  std::vector<TimedViseme> out;
  for (const auto& p : phonemes) {
    if (p.start_ms > duration_ms) break;
    Viseme v = visemeFor(p.phoneme);
    if (!out.empty() && out.back().viseme.name == v.name) continue;
    if (!out.empty() && out.back().t_ms == p.start_ms) {
      out.back().viseme = std::move(v);  // zero-length phoneme: the later one wins
      continue;
    }
    out.push_back({p.start_ms, std::move(v)});
  }
  if (out.empty() || out.back().viseme.name != "sil" || out.back().t_ms > duration_ms) {
    out.push_back({duration_ms, shape(sil)});
  }
  return out;
}

}  // namespace skr::wsui
