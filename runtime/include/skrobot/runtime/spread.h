// SPDX-License-Identifier: Apache-2.0
// How a set of timings spreads: p50, p99 and max, and the period errors of a series of instants
// (for benchmarks and tools that report timing).
#pragma once

#include <skrobot/runtime/clock.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace skr {

struct Spread {
  double p50 = 0, p99 = 0, max = 0;
};

// The spread of `v` (sorted here); zeros when empty.
inline Spread spreadOf(std::vector<double> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  return {v[v.size() / 2], v[std::min(v.size() - 1, v.size() * 99 / 100)], v.back()};
}

// |interval - nominal_ns| between consecutive `times`, in microseconds.
inline std::vector<double> periodErrorsUs(const std::vector<Nanos>& times, double nominal_ns) {
  std::vector<double> e;
  for (size_t i = 1; i < times.size(); ++i) {
    e.push_back(std::abs(static_cast<double>(times[i] - times[i - 1]) - nominal_ns) / 1e3);
  }
  return e;
}

}  // namespace skr
