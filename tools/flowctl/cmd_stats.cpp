// flowctl top, hz, bw, info and graph: the hub's statistics (hub.stats, hub.inspect; see
// docs/observability.md) and a channel's rate measured here.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>

#include "session.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

const Variant kNull;

const Variant& at(const Variant& v, std::string_view key) {
  const Variant* p = v.find(key);
  return p != nullptr ? *p : kNull;
}
double num(const Variant& v, std::string_view key) {
  return at(v, key).asDouble().value_or(0);
}
std::string str(const Variant& v, std::string_view key) {
  const std::string* s = at(v, key).asString();
  return s != nullptr ? *s : std::string();
}
const Variant::List& list(const Variant& v, std::string_view key) {
  static const Variant::List kEmpty;
  const Variant::List* l = at(v, key).asList();
  return l != nullptr ? *l : kEmpty;
}
// The path the k-th of a channel's subscriber_flows takes: relay, direct or shm ("" from a hub
// that does not say).
std::string subscriberPath(const Variant& channel, size_t k) {
  const auto& paths = list(channel, "subscriber_paths");
  const std::string* p = k < paths.size() ? paths[k].asString() : nullptr;
  return p != nullptr ? *p : std::string();
}

std::string human(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB"};
  int u = 0;
  while (bytes >= 1024 && u < 3) bytes /= 1024, ++u;
  char buf[32];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", bytes, units[u]);
  return buf;
}

// The hub's statistics asked of hub.inspect (rates over the last second and the last ten, the
// same for every reader until the hub's next one-second tick).
std::optional<Variant> fetchStats(const Cli& cli, int& code) {
  auto sync = connectSync(cli, code);
  if (!sync) return std::nullopt;
  auto info = sync->channel("hub.inspect");
  if (!info) {
    code = fail(kNotFound, "this hub has no hub.inspect service (a hub older than 0.2?)");
    return std::nullopt;
  }
  auto answer = sync->call(info->id, "stats", Variant(), 5000);
  if (!answer) {
    code = fail(exitFor(answer.error()), "hub.inspect: " + answer.error().message);
    return std::nullopt;
  }
  if (!at(*answer, "channels").isList()) {
    code = fail(kFailed, "hub.inspect answered no statistics");
    return std::nullopt;
  }
  return std::move(answer).value();
}

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
  return out;
}

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
int measure(const Cli& cli, const char* usage, bool bandwidth) {
  Args args(cli.args);
  const auto window_text = args.option("--window");
  const auto count_text = args.option("--count");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1) return fail(kUsage, usage);
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

// A channel's rates over the hub's windows (the last second, the last ten): a channel younger
// than a window was measured over its age. An older hub gives one interval only.
void printRates(const Variant& stats, const Variant& row) {
  const auto line = [&](const char* label, const std::string& suffix, double window_s) {
    const double age = num(row, "age_s");
    std::printf("  %-12s %.1f Hz, %s/s over the last %.1f s%s\n", label, num(row, "hz" + suffix),
                human(num(row, "bytes_per_s" + suffix)).c_str(), std::min(window_s, age),
                age < window_s ? " (since it began)" : "");
  };
  if (row.find("hz_10s") == nullptr) {
    std::printf("  rate         %.1f Hz, %s/s (over the last %.1f s)\n", num(row, "hz"),
                human(num(row, "bytes_per_s")).c_str(), num(stats, "interval_s"));
    return;
  }
  if (num(row, "age_s") <= 0) {
    std::printf("  rate         none yet (it began less than a second ago)\n");
    return;
  }
  line("rate", "", num(stats, "interval_s"));
  line("", "_10s", num(stats, "interval_10s_s"));
}

std::string dotId(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

int cmdTop(const Cli& cli) {
  Args args(cli.args);
  const std::string sort = args.option("--sort").value_or("hz");
  const auto rows_text = args.option("--rows");
  const bool once = args.flag("--once");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (!rest.empty())
    return fail(kUsage, "usage: flowctl top [--sort hz|bw|drops|name] [--rows N] [--once]");
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

int cmdHz(const Cli& cli) {
  return measure(cli, "usage: flowctl hz CHANNEL [--window N] [--count N]", false);
}

int cmdBw(const Cli& cli) {
  return measure(cli, "usage: flowctl bw CHANNEL [--window N] [--count N]", true);
}

int cmdInfo(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1) return fail(kUsage, "usage: flowctl info CHANNEL");
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto info = sync->channel(rest[0]);
  if (!info) return fail(exitFor(info.error()), "no such channel " + rest[0]);
  auto stats = fetchStats(cli, code);
  if (!stats) return code;
  const Variant* row = nullptr;
  for (const Variant& c : list(*stats, "channels")) {
    if (str(c, "name") == rest[0]) row = &c;
  }
  std::map<uint64_t, std::string> flow_names;
  for (const Variant& f : list(*stats, "flows")) {
    flow_names[at(f, "id").asUint64().value_or(0)] = str(f, "name") + " (" + str(f, "kind") + ")";
  }
  Variant::List subscribers;
  if (row != nullptr) {
    const auto& ids = list(*row, "subscriber_flows");
    for (size_t k = 0; k < ids.size(); ++k) {
      const std::string path = subscriberPath(*row, k);
      std::string name = flow_names[ids[k].asUint64().value_or(0)];
      if (path == "direct") name += " by a direct path";
      if (path == "shm") name += " by shared memory";
      subscribers.emplace_back(std::move(name));
    }
  }
  Variant out = Variant::Map{
      {"name", info->name},
      {"kind",
       std::string(skr::flow::channelKindName(static_cast<skr::flow::ChannelKind>(info->kind)))},
      {"mime", info->mime},
      {"owner", row != nullptr ? at(*row, "owner") : Variant(info->owner)},
      {"subscribers", subscribers},
      {"properties", info->props}};
  if (row != nullptr) {
    for (const char* key :
         {"hz", "bytes_per_s", "messages", "bytes", "dropped", "dropped_per_s", "pending_requests",
          "hz_10s", "bytes_per_s_10s", "dropped_per_s_10s", "age_s"}) {
      if (row->find(key) != nullptr) out.asMap()->emplace(key, at(*row, key));
    }
  }
  if (cli.json) {
    std::printf("%s\n", skr::flow::variantToJsonText(out).c_str());
    return kOk;
  }
  std::printf("%s  (%s, %s)\n", info->name.c_str(), str(out, "kind").c_str(),
              info->mime.empty() ? "no mime type" : info->mime.c_str());
  std::printf("  owner        %s\n", str(out, "owner").c_str());
  std::printf("  subscribers  %zu\n", subscribers.size());
  for (const Variant& s : subscribers) std::printf("    %s\n", s.asString()->c_str());
  if (row != nullptr) {
    printRates(*stats, *row);
    std::printf("  total        %.0f messages, %s, %.0f dropped\n", num(*row, "messages"),
                human(num(*row, "bytes")).c_str(), num(*row, "dropped"));
    if (num(*row, "pending_requests") > 0) {
      std::printf("  pending      %.0f requests\n", num(*row, "pending_requests"));
    }
  }
  std::printf("  properties   %s\n", skr::flow::variantToJsonText(info->props).c_str());
  return kOk;
}

int cmdGraph(const Cli& cli) {
  Args args(cli.args);
  const bool all = args.flag("--all");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (!rest.empty()) return fail(kUsage, "usage: flowctl graph [--all]");
  int code = kOk;
  auto stats = fetchStats(cli, code);
  if (!stats) return code;
  std::map<uint64_t, const Variant*> flows;
  for (const Variant& f : list(*stats, "flows")) flows[at(f, "id").asUint64().value_or(0)] = &f;
  std::string out = "digraph " + dotId(str(*stats, "hub")) +
                    " {\n  rankdir=LR;\n  node [fontname=\"sans-serif\", fontsize=10];\n";
  std::map<uint64_t, bool> used;
  std::string edges;
  for (const Variant& c : list(*stats, "channels")) {
    const std::string name = str(c, "name");
    if (!all && name.rfind("hub.", 0) == 0) continue;  // the hub's own statistics
    const bool service = str(c, "kind") == "service";
    char label[256];
    std::snprintf(label, sizeof label, "%s\\n%.1f Hz  %s/s", name.c_str(), num(c, "hz"),
                  human(num(c, "bytes_per_s")).c_str());
    out += "  " + dotId("c:" + name) + " [shape=ellipse, label=\"" + label + "\"" +
           (service ? ", style=dashed" : "") + (num(c, "dropped_per_s") > 0 ? ", color=red" : "") +
           "];\n";
    const uint64_t owner = at(c, "owner_flow").asUint64().value_or(0);
    if (owner != 0) {
      used[owner] = true;
      edges += "  " + dotId("f:" + std::to_string(owner)) + " -> " + dotId("c:" + name) + ";\n";
    }
    const auto& subscribers = list(c, "subscriber_flows");
    for (size_t k = 0; k < subscribers.size(); ++k) {
      const uint64_t f = subscribers[k].asUint64().value_or(0);
      used[f] = true;
      const std::string path = subscriberPath(c, k);
      const std::string style = path == "shm"      ? " [style=dotted, label=\"shared memory\"]"
                                : path == "direct" ? " [style=dashed, label=\"direct\"]"
                                                   : "";
      edges += "  " + dotId("c:" + name) + " -> " + dotId("f:" + std::to_string(f)) + style + ";\n";
    }
  }
  for (const auto& [id, f] : flows) {
    if (!used[id]) continue;
    const bool slow = num(*f, "dropped_per_s") > 0 || num(*f, "queue_fill") >= 0.5;
    out += "  " + dotId("f:" + std::to_string(id)) +
           " [shape=box, label=" + dotId(str(*f, "name") + " (" + str(*f, "kind") + ")") +
           (slow ? ", color=red" : "") + "];\n";
  }
  out += edges + "}\n";
  std::fwrite(out.data(), 1, out.size(), stdout);
  return kOk;
}

}  // namespace flowctl
