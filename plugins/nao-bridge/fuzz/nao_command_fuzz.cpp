// SPDX-License-Identifier: Apache-2.0
// Fuzz target: parseCommand on arbitrary text. Accepted commands stay within the limits the
// parser promises; refusals carry a code and a message.
#include "commands.h"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const skr::nao::Parsed p = skr::nao::parseCommand(text, size % 2 == 0 ? "head" : "");
  if (!p.result.ok()) {
    if (p.result.message.empty()) std::abort();
    return 0;
  }
  if (const auto* s = std::get_if<skr::nao::Say>(&p.command)) {
    if (s->text.size() > skr::nao::kMaxSayBytes) std::abort();
  }
  if (const auto* j = std::get_if<skr::nao::Joints>(&p.command)) {
    if (j->names.size() != j->angles.size() || !(j->speed > 0 && j->speed <= 1)) std::abort();
    for (double a : j->angles) {
      if (!std::isfinite(a)) std::abort();
    }
  }
  if (const auto* w = std::get_if<skr::nao::Walk>(&p.command)) {
    if (std::fabs(w->x) > 1 || std::fabs(w->y) > 1 || std::fabs(w->theta) > 1) std::abort();
  }
  (void)p.result.json();
  return 0;
}
