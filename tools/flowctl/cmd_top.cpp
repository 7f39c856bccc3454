// SPDX-License-Identifier: Apache-2.0
// flowctl top: the hub's channels by rate, bandwidth or drops, and its slow flows, from hub.stats
// (docs/observability.md).
#include <unistd.h>

#include <algorithm>

#include "hub_stats.h"
#include "session.h"

namespace flowctl {

using namespace hubstats;

namespace {

// One table of channels (sorted) and of the flows that are behind.
std::string topTable(const Variant& stats, const std::string& sort, size_t rows) {
  std::vector<const Variant*> channels;
  for (const Variant& c : list(stats, "channels")) channels.push_back(&c);
  std::stable_sort(channels.begin(), channels.end(), [&](const Variant* a, const Variant* b) {
    if (sort == "name") return str(*a, "name") < str(*b, "name");
    if (sort == "drops") return num(*a, "dropped_per_s") > num(*b, "dropped_per_s");
    if (sort == "bw") return num(*a, "bytes_per_s") > num(*b, "bytes_per_s");
    return num(*a, "hz") > num(*b, "hz");
  });
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "hub %s: %zu channels, %zu flows\n\n", str(stats, "hub").c_str(),
                channels.size(), list(stats, "flows").size());
  out += line;
  std::snprintf(line, sizeof line, "%-40s %-9s %9s %12s %5s %8s  %s\n", "CHANNEL", "KIND", "HZ",
                "BANDWIDTH", "SUBS", "DROP/S", "OWNER");
  out += line;
  for (size_t i = 0; i < channels.size() && i < rows; ++i) {
    const Variant& c = *channels[i];
    std::snprintf(line, sizeof line, "%-40s %-9s %9.1f %10s/s %5.0f %8.1f  %s\n",
                  str(c, "name").c_str(), str(c, "kind").c_str(), num(c, "hz"),
                  human(num(c, "bytes_per_s")).c_str(), num(c, "subscribers"),
                  num(c, "dropped_per_s"), str(c, "owner").c_str());
    out += line;
  }
  if (channels.size() > rows) out += "... " + std::to_string(channels.size() - rows) + " more\n";
  // Flows that drop or whose queue is filling: the slow subscribers.
  std::string slow;
  for (const Variant& f : list(stats, "flows")) {
    if (num(f, "dropped_per_s") <= 0 && num(f, "queue_fill") < 0.25) continue;
    std::snprintf(line, sizeof line, "%-40s %-9s %9.1f %8.0f%% %8.1f %8.0f\n",
                  str(f, "name").c_str(), str(f, "kind").c_str(), num(f, "out_hz"),
                  num(f, "queue_fill") * 100, num(f, "dropped_per_s"), num(f, "pending_requests"));
    slow += line;
  }
  if (!slow.empty()) {
    std::snprintf(line, sizeof line, "\n%-40s %-9s %9s %9s %8s %8s\n", "SLOW FLOW", "KIND",
                  "OUT HZ", "QUEUE", "DROP/S", "PENDING");
    out += line + slow;
  }
  // Serial lines (server.serial): their traffic and what the line's checks dropped.
  const Variant::List& serial = list(stats, "serial");
  if (!serial.empty()) {
    std::snprintf(line, sizeof line, "\n%-32s %-8s %10s %10s %9s %9s %8s %8s\n", "SERIAL PORT",
                  "STATE", "BYTES IN", "BYTES OUT", "FRAMES IN", "BAD CHECK", "RESYNCS",
                  "SESSIONS");
    out += line;
    for (const Variant& p : serial) {
      const char* state = at(p, "in_session").asBool().value_or(false) ? "session"
                          : at(p, "open").asBool().value_or(false)     ? "open"
                                                                       : "away";
      std::snprintf(line, sizeof line, "%-32s %-8s %10s %10s %9.0f %9.0f %8.0f %8.0f\n",
                    str(p, "device").c_str(), state, human(num(p, "bytes_in")).c_str(),
                    human(num(p, "bytes_out")).c_str(), num(p, "frames_in"), num(p, "bad_check"),
                    num(p, "resyncs"), num(p, "sessions"));
      out += line;
    }
  }
  // Boards over UDP (server.udp): sessions, traffic and what the checks refused.
  const Variant& udp = at(stats, "udp");
  if (udp.find("port") != nullptr) {
    std::snprintf(line, sizeof line, "\n%-10s %8s %12s %12s %8s %8s %8s %9s\n", "UDP PORT",
                  "SESSIONS", "DATAGR. IN", "DATAGR. OUT", "BAD MAC", "REPLAYED", "LOST",
                  "REORDERED");
    out += line;
    std::snprintf(line, sizeof line, "%-10.0f %8.0f %12.0f %12.0f %8.0f %8.0f %8.0f %9.0f\n",
                  num(udp, "port"), num(udp, "open_sessions"), num(udp, "datagrams_in"),
                  num(udp, "datagrams_out"), num(udp, "bad_mac"), num(udp, "replayed"),
                  num(udp, "lost"), num(udp, "reordered"));
    out += line;
  }
  return out;
}

}  // namespace

int cmdTop(const Cli& cli) {
  Args args(cli.args);
  const std::string sort = args.option("--sort").value_or("hz");
  const auto rows_text = args.option("--rows");
  const bool once = args.flag("--once");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (!rest.empty()) return usageError(cli);
  if (sort != "hz" && sort != "bw" && sort != "drops" && sort != "name") {
    return fail(kUsage, "--sort is hz, bw, drops or name, not '" + sort + "'");
  }
  double rows = 30;
  if (rows_text && !parseNumber(*rows_text, "--rows", rows)) return kUsage;
  const bool tty = ::isatty(1) == 1;
  Session s(cli, 100 * skr::kNsPerMs);
  s.satellite.data.connect(&s.satellite, [&](uint16_t id, const std::string& payload) {
    const auto* info = s.satellite.channel(id);
    if (info == nullptr || info->name != "hub.stats") return;
    if (cli.json) {
      std::printf("%s\n", payload.c_str());
    } else if (auto stats = skr::flow::variantFromJsonText(payload)) {
      std::printf("%s%s\n", tty && !once ? "\x1b[H\x1b[2J" : "",
                  topTable(*stats, sort, static_cast<size_t>(rows)).c_str());
    }
    std::fflush(stdout);
    if (once) s.end(kOk, "");
  });
  s.satellite.subscribe("hub.stats");
  return s.run();
}

}  // namespace flowctl
