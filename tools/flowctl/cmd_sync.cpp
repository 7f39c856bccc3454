// SPDX-License-Identifier: Apache-2.0
// flowctl sync: a sync pulse source at a rate, or a follower that prints each pulse and, at the
// end, how regular they came (docs/sync-pulse.md).
#include <algorithm>
#include <cmath>
#include <vector>

#include <skrobot/runtime/spread.h>

#include "session.h"

namespace flowctl {

namespace {

using skr::Nanos;

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

void printSpread(bool json, const char* what, const skr::Spread& s) {
  if (json) {
    std::printf("\"%s\":{\"p50_us\":%.1f,\"p99_us\":%.1f,\"max_us\":%.1f}", what, s.p50, s.p99,
                s.max);
  } else {
    std::printf("%s: p50 %.1f us, p99 %.1f us, max %.1f us\n", what, s.p50, s.p99, s.max);
  }
}

int source(const Cli& cli, const std::string& name, double hz, double count) {
  std::string full = name, short_name;
  {
    int code = kOk;
    auto sync = connectSync(cli, code);
    if (!sync) return code;
    const std::string prefix = sync->login().user + ".";
    if (full.find('.') == std::string::npos) full = prefix + full;
    if (!full.starts_with(prefix)) return fail(kDenied, full + " is not yours");
    short_name = full.substr(prefix.size());
  }
  // Fast rates need the loop's spinning mode to keep their cadence.
  const auto mode = hz > 100 ? skr::TimingMode::pseudo_realtime : skr::TimingMode::coarse;
  Session s(cli, static_cast<Nanos>(1e9 / hz), mode);
  if (auto added =
          s.satellite.addChannel({.name = short_name, .kind = skr::flow::ChannelKind::sync});
      !added) {
    return fail(kUsage, added.error().message);
  }
  bool ready = false;
  std::vector<Nanos> sent;
  s.satellite.channelReady.connect(&s.satellite, [&](const sat::ChannelInfo&) { ready = true; });
  s.loop.addTickHandler(skr::Tick::fast, [&] {
    if (!ready || !s.satellite.isConnected()) return;
    if (auto r = s.satellite.pulse(short_name); !r) return s.end(kFailed, r.error().message);
    sent.push_back(skr::monotonicNs());
    if (count > 0 && sent.size() >= static_cast<size_t>(count)) s.loop.stop();
  });
  const int code = s.run();
  if (code != kOk) return code;
  const skr::Spread own = skr::spreadOf(skr::periodErrorsUs(sent, 1e9 / hz));
  if (cli.json) {
    std::printf("{\"source\":\"%s\",\"pulses\":%zu,", full.c_str(), sent.size());
    printSpread(true, "period_error", own);
    std::printf("}\n");
  } else {
    std::printf("%zu pulses on %s at %.1f Hz\n", sent.size(), full.c_str(), hz);
    printSpread(false, "period error", own);
  }
  return kOk;
}

int follow(const Cli& cli, const std::string& name, double every, double count) {
  {
    int code = kOk;
    auto sync = connectSync(cli, code);
    if (!sync) return code;
    auto info = sync->channel(name);
    if (!info) return fail(exitFor(info.error()), info.error().message);
    if (info->kind != uint8_t(skr::flow::ChannelKind::sync)) {
      return fail(kFailed, name + " is not a sync source");
    }
  }
  Session s(cli, 100 * skr::kNsPerMs);
  std::vector<Nanos> arrivals;
  std::vector<double> delays_us;
  uint64_t dropped = 0, missed = 0, last_seq = 0;
  s.satellite.syncPulse.connect(&s.satellite, [&](const sat::SyncPulse& p) {
    const double delay_us =
        static_cast<double>(p.arrival_ns - static_cast<Nanos>(p.source_time_ns)) / 1e3;
    const double period_ms =
        arrivals.empty() ? 0 : static_cast<double>(p.arrival_ns - arrivals.back()) / 1e6;
    // Pulses that every-N does not skip but that never came (a lost connection, say).
    const auto step = static_cast<uint64_t>(std::max(every, 1.0));
    if (last_seq != 0 && p.seq > last_seq + step * (1 + p.dropped)) {
      missed += (p.seq - last_seq) / step - 1 - p.dropped;
    }
    last_seq = p.seq;
    dropped += p.dropped;
    arrivals.push_back(p.arrival_ns);
    delays_us.push_back(delay_us);
    if (cli.json) {
      std::printf("{\"seq\":%llu,\"period_ms\":%.3f,\"delay_us\":%.1f,\"dropped\":%u}\n",
                  (unsigned long long)p.seq, period_ms, delay_us, p.dropped);
    } else {
      std::printf("pulse %llu  period %.3f ms  delay %.1f us%s\n", (unsigned long long)p.seq,
                  period_ms, delay_us,
                  p.dropped > 0 ? ("  dropped " + std::to_string(p.dropped)).c_str() : "");
    }
    std::fflush(stdout);
    if (count > 0 && arrivals.size() >= static_cast<size_t>(count)) s.loop.stop();
  });
  s.satellite.follow(name, static_cast<uint32_t>(std::max(every, 1.0)));
  const int code = s.run();
  if (code != kOk) return code;
  std::vector<double> intervals;
  for (size_t i = 1; i < arrivals.size(); ++i) {
    intervals.push_back(static_cast<double>(arrivals[i] - arrivals[i - 1]));
  }
  const double nominal = median(intervals);  // the period the pulses came at
  const skr::Spread err = skr::spreadOf(skr::periodErrorsUs(arrivals, nominal));
  const skr::Spread delay = skr::spreadOf(delays_us);
  if (cli.json) {
    std::printf(
        "{\"source\":\"%s\",\"pulses\":%zu,\"period_ms\":%.3f,\"dropped\":%llu,"
        "\"missed\":%llu,",
        name.c_str(), arrivals.size(), nominal / 1e6, (unsigned long long)dropped,
        (unsigned long long)missed);
    printSpread(true, "period_error", err);
    std::printf(",");
    printSpread(true, "delay", delay);
    std::printf("}\n");
  } else {
    std::printf("%zu pulses of %s, period %.3f ms; dropped %llu (busy), missed %llu\n",
                arrivals.size(), name.c_str(), nominal / 1e6, (unsigned long long)dropped,
                (unsigned long long)missed);
    printSpread(false, "period error", err);
    printSpread(false, "source-to-here delay", delay);
  }
  return kOk;
}

}  // namespace

int cmdSync(const Cli& cli) {
  Args args(cli.args);
  const auto hz_text = args.option("--hz");
  const auto count_text = args.option("--count");
  const auto every_text = args.option("--every");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 2 || (rest[0] != "source" && rest[0] != "follow")) return usageError(cli);
  double hz = 0, count = 0, every = 1;
  if (count_text && !parseNumber(*count_text, "--count", count)) return kUsage;
  if (every_text && !parseNumber(*every_text, "--every", every)) return kUsage;
  if (rest[0] == "source") {
    if (!hz_text) return fail(kUsage, "flowctl sync source needs --hz");
    if (!parseNumber(*hz_text, "--hz", hz)) return kUsage;
    if (hz <= 0 || hz > 100000) return fail(kUsage, "--hz is above 0 and at most 100000");
    return source(cli, rest[1], hz, count);
  }
  return follow(cli, rest[1], every, count);
}

}  // namespace flowctl
