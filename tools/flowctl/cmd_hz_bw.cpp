// SPDX-License-Identifier: Apache-2.0
// flowctl hz and bw: a streaming channel's rate or bandwidth, measured here once a second.
#include <algorithm>
#include <cmath>
#include <deque>

#include "hub_stats.h"
#include "session.h"

namespace flowctl {

using hubstats::human;

namespace {

// Arrival times (ns) and sizes of the last `window` messages of a channel.
struct Window {
  size_t max = 100;
  std::deque<std::pair<skr::Nanos, size_t>> items;
  void add(skr::Nanos t, size_t bytes) {
    items.emplace_back(t, bytes);
    while (items.size() > max) items.pop_front();
  }
};

// hz and bw: subscribe and print once a second until --count lines (0: until Ctrl-C).
int measure(const Cli& cli, bool bandwidth) {
  Args args(cli.args);
  const auto window_text = args.option("--window");
  const auto count_text = args.option("--count");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1) return usageError(cli);
  double window = 100, count = 0;
  if (window_text && (!parseNumber(*window_text, "--window", window) || window < 2)) {
    return fail(kUsage, "--window takes 2 messages or more");
  }
  if (count_text && !parseNumber(*count_text, "--count", count)) return kUsage;
  const std::string name = rest[0];
  Session s(cli, 100 * skr::kNsPerMs);
  Window w;
  w.max = static_cast<size_t>(window);
  uint64_t lines = 0;
  s.satellite.data.connect(&s.satellite, [&](uint16_t id, const std::string& payload) {
    const auto* info = s.satellite.channel(id);
    if (info != nullptr && info->name == name) w.add(skr::monotonicNs(), payload.size());
  });
  s.loop.addTickHandler(skr::Tick::one_sec, [&] {
    const size_t n = w.items.size();
    char line[256];
    if (n < 2) {
      std::snprintf(line, sizeof line,
                    cli.json ? R"({"channel":"%s","messages":%zu})" : "%s: %zu messages so far",
                    name.c_str(), n);
    } else if (!bandwidth) {
      double sum = 0, sq = 0, lo = 1e300, hi = 0;
      for (size_t i = 1; i < n; ++i) {
        const double d = static_cast<double>(w.items[i].first - w.items[i - 1].first) / 1e9;
        sum += d, sq += d * d, lo = std::min(lo, d), hi = std::max(hi, d);
      }
      const double mean = sum / static_cast<double>(n - 1);
      const double sd = std::sqrt(std::max(0.0, sq / static_cast<double>(n - 1) - mean * mean));
      std::snprintf(
          line, sizeof line,
          cli.json
              ? R"({"channel":"%s","hz":%.3f,"min_s":%.6f,"max_s":%.6f,"std_s":%.6f,"window":%zu})"
              : "%s: %.3f Hz  min %.4f s  max %.4f s  std dev %.5f s  window %zu",
          name.c_str(), 1 / mean, lo, hi, sd, n);
    } else {
      double bytes = 0, lo = 1e300, hi = 0;
      for (size_t i = 1; i < n; ++i) {
        const double b = static_cast<double>(w.items[i].second);
        bytes += b, lo = std::min(lo, b), hi = std::max(hi, b);
      }
      const double span = static_cast<double>(w.items.back().first - w.items.front().first) / 1e9;
      const double per_s = span > 0 ? bytes / span : 0, mean = bytes / static_cast<double>(n - 1);
      if (cli.json) {
        std::snprintf(line, sizeof line,
                      R"({"channel":"%s","bytes_per_s":%.1f,"mean_bytes":%.1f,"min_bytes":%.0f,)"
                      R"("max_bytes":%.0f,"window":%zu})",
                      name.c_str(), per_s, mean, lo, hi, n);
      } else {
        std::snprintf(line, sizeof line, "%s: %s/s  mean %s  min %s  max %s  window %zu",
                      name.c_str(), human(per_s).c_str(), human(mean).c_str(), human(lo).c_str(),
                      human(hi).c_str(), n);
      }
    }
    std::printf("%s\n", line);
    std::fflush(stdout);
    if (count > 0 && ++lines >= static_cast<uint64_t>(count)) s.loop.stop();
  });
  s.satellite.subscribe(name);
  return s.run();
}

}  // namespace

int cmdHz(const Cli& cli) {
  return measure(cli, false);
}

int cmdBw(const Cli& cli) {
  return measure(cli, true);
}

}  // namespace flowctl
