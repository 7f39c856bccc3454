// SPDX-License-Identifier: Apache-2.0
#include "visemes.h"

namespace skr::wsui {

Viseme visemeFor(std::string_view ph) {
  while (!ph.empty() &&
         (ph.front() == '\'' || ph.front() == ',' || ph.front() == '%' || ph.front() == '=')) {
    ph.remove_prefix(1);  // stress marks
  }
  if (ph.empty() || ph.front() == '_' || ph.front() == ' ') return {"rest", 0, 0, 0};
  const char c = ph.front();
  switch (c) {
    case 'a':
    case 'A':
    case 'V':
    case '&':
    case 'Q':
      return {"AA", 0.85, 0.35, 0.0};
    case 'e':
    case 'E':
    case 'i':
    case 'I':
    case 'j':
    case 'y':
      return {"EE", 0.35, 0.9, 0.0};
    case '@':
    case '3':
      return {"AA", 0.5, 0.3, 0.0};
    case 'o':
    case 'O':
    case 'u':
    case 'U':
    case 'w':
      return {"OO", 0.45, 0.0, 0.95};
    case 'p':
    case 'b':
    case 'm':
      return {"MBP", 0.0, 0.2, 0.1};
    case 'f':
    case 'v':
      return {"FV", 0.15, 0.45, 0.0};
    default:
      return {"CH", 0.25, 0.4, 0.1};  // other consonants: a small, neutral opening
  }
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
  if (out.empty() || out.back().viseme.name != "rest" || out.back().t_ms > duration_ms) {
    out.push_back({duration_ms, visemeFor("_")});
  }
  return out;
}

}  // namespace skr::wsui
