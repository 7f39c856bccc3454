// SPDX-License-Identifier: Apache-2.0
// Tick timing benchmark: for each timing mode at fast intervals of 1 ms and 10 ms, the error of
// each fast tick period against the nominal interval (p50/p99/max of |period - interval|), the
// drift of the mean period, and the loop thread's CPU use. The baseline is the OS floor measured
// in the same run: a thread sleeping to absolute deadlines with clock_nanosleep(TIMER_ABSTIME).
//
//   tick_timing [--seconds S]   (default 2 s per row)
#include <skrobot/runtime/loop.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

using skr::Nanos;

struct Row {
  std::string mode;
  double interval_ms = 0;
  size_t ticks = 0;
  double p50_us = 0, p99_us = 0, max_us = 0;
  double mean_period_us = 0;
  double cpu_pct = 0;
};

Row summarize(std::string mode, Nanos interval, const std::vector<Nanos>& stamps, Nanos cpu_ns,
              Nanos wall_ns) {
  Row r;
  r.mode = std::move(mode);
  r.interval_ms = static_cast<double>(interval) / 1e6;
  r.ticks = stamps.size();
  std::vector<double> err;
  for (size_t i = 1; i < stamps.size(); ++i) {
    err.push_back(std::abs(static_cast<double>(stamps[i] - stamps[i - 1] - interval)) / 1e3);
  }
  if (!err.empty()) {
    std::sort(err.begin(), err.end());
    r.p50_us = err[err.size() / 2];
    r.p99_us = err[std::min(err.size() - 1, err.size() * 99 / 100)];
    r.max_us = err.back();
    r.mean_period_us =
        static_cast<double>(stamps.back() - stamps.front()) / 1e3 / (stamps.size() - 1);
  }
  r.cpu_pct = 100.0 * static_cast<double>(cpu_ns) / static_cast<double>(wall_ns);
  return r;
}

Row runBaseline(Nanos interval, double seconds) {
  std::vector<Nanos> stamps;
  const Nanos start = skr::monotonicNs();
  const Nanos cpu0 = skr::threadCpuNs();
  Nanos deadline = start + interval;
  const Nanos end = start + static_cast<Nanos>(seconds * 1e9);
  while (deadline < end) {
    timespec ts{static_cast<time_t>(deadline / skr::kNsPerSec),
                static_cast<long>(deadline % skr::kNsPerSec)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
    stamps.push_back(skr::monotonicNs());
    deadline += interval;
  }
  return summarize("baseline", interval, stamps, skr::threadCpuNs() - cpu0,
                   skr::monotonicNs() - start);
}

Row runLoop(skr::TimingMode mode, Nanos interval, double seconds) {
  skr::LoopOptions o;
  o.name = "bench";
  o.mode = mode;
  o.fast_interval_ns = interval;
  o.slow_interval_ns = interval * 10;
  skr::Loop loop(o);
  std::vector<Nanos> stamps;
  stamps.reserve(static_cast<size_t>(seconds * 1e9 / interval) + 16);
  loop.addTickHandler(skr::Tick::fast, [&] { stamps.push_back(skr::monotonicNs()); });
  const Nanos start = skr::monotonicNs();
  const Nanos cpu0 = skr::threadCpuNs();
  loop.runFor(static_cast<Nanos>(seconds * 1e9));
  return summarize(std::string(skr::timingModeName(mode)), interval, stamps,
                   skr::threadCpuNs() - cpu0, skr::monotonicNs() - start);
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 2.0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--seconds") == 0 && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: tick_timing [--seconds S]\n");
      return 2;
    }
  }
  if (seconds <= 0) seconds = 2.0;
  std::printf(
      "tick timing, %.1f s per row; error = |period - interval|; ratio = p99 / baseline "
      "p99\n\n",
      seconds);
  std::printf("%-16s %9s %7s %9s %9s %9s %12s %7s %8s\n", "mode", "interval", "ticks", "p50 us",
              "p99 us", "max us", "mean period", "cpu %", "p99 x");
  for (Nanos interval : {skr::kNsPerMs, 10 * skr::kNsPerMs}) {
    const Row base = runBaseline(interval, seconds);
    std::vector<Row> rows{base};
    for (auto mode : {skr::TimingMode::coarse, skr::TimingMode::pseudo_realtime,
                      skr::TimingMode::socket_driven, skr::TimingMode::none}) {
      rows.push_back(runLoop(mode, interval, seconds));
    }
    for (const auto& r : rows) {
      const bool none = r.mode == "none";  // no interval: ticks back to back
      std::printf("%-16s %7.0fms %7zu %9.1f %9.1f %9.1f %10.1fus %7.1f", r.mode.c_str(),
                  r.interval_ms, r.ticks, none ? 0.0 : r.p50_us, none ? 0.0 : r.p99_us,
                  none ? 0.0 : r.max_us, r.mean_period_us, r.cpu_pct);
      if (none || base.p99_us <= 0) {
        std::printf(" %8s\n", "-");
      } else {
        std::printf(" %8.2f\n", r.p99_us / base.p99_us);
      }
    }
    std::printf("\n");
  }
  return 0;
}
