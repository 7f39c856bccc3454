// SPDX-License-Identifier: Apache-2.0
// flowctl ps, start, stop, restart and logs: the hub's supervised satellites (docs/robot.md;
// ADMIN sat_ps, sat_start, sat_stop, sat_restart, sat_logs; administrators only).
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <string>
#include <thread>

#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

std::string uptime(const Variant& sat) {
  const std::string text = field(sat, "uptime_s");
  if (field(sat, "pid") == "0" || text.empty()) return "-";
  const auto s = static_cast<int64_t>(std::floor(std::strtod(text.c_str(), nullptr)));
  if (s < 60) return std::to_string(s) + "s";
  if (s < 3600) return std::to_string(s / 60) + "m" + std::to_string(s % 60) + "s";
  return std::to_string(s / 3600) + "h" + std::to_string(s % 3600 / 60) + "m";
}

// A list of strings as "a,b,c" ("-" when empty).
std::string joined(const Variant& map, const char* key, const char* member = nullptr) {
  std::string out;
  const auto* m = map.asMap();
  if (m == nullptr) return "-";
  auto it = m->find(key);
  if (it == m->end() || it->second.asList() == nullptr) return "-";
  for (const auto& v : *it->second.asList()) {
    if (!out.empty()) out += ",";
    out += member != nullptr ? field(v, member) : (v.asString() ? *v.asString() : "");
  }
  return out.empty() ? "-" : out;
}

int named(const Cli& cli, const char* command) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (rest.size() != 1 || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, command, Variant::Map{{"name", rest[0]}}, [](const Variant& a) {
    std::printf("%s %s\n", field(a, "name").c_str(), field(a, "state").c_str());
  });
}

void printLines(const Variant& answer) {
  const auto* m = answer.asMap();
  if (m == nullptr) return;
  auto it = m->find("lines");
  if (it == m->end() || it->second.asList() == nullptr) return;
  for (const auto& l : *it->second.asList()) {
    std::printf("%s%s\n", field(l, "stream") == "stderr" ? "! " : "", field(l, "text").c_str());
  }
  std::fflush(stdout);
}

}  // namespace

int cmdPs(const Cli& cli) {
  Args args(cli.args);
  if (!args.rest().empty() || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, "sat_ps", Variant(), [](const Variant& answer) {
    std::printf("%-16s %-9s %8s %8s %8s %-34s %-8s %s\n", "NAME", "STATE", "PID", "UPTIME",
                "RESTARTS", "LAST EXIT", "FLOWS", "CHANNELS");
    if (const auto* list = answer.asList()) {
      for (const auto& s : *list) {
        std::string state = field(s, "state");
        if (state == "waiting") state += " for " + joined(s, "waiting_for");
        std::printf("%-16s %-9s %8s %8s %8s %-34s %-8s %s\n", field(s, "name").c_str(),
                    state.c_str(), field(s, "pid") == "0" ? "-" : field(s, "pid").c_str(),
                    uptime(s).c_str(), field(s, "restarts").c_str(),
                    field(s, "last_exit").empty() ? "-" : field(s, "last_exit").c_str(),
                    joined(s, "flows", "id").c_str(), joined(s, "channels").c_str());
      }
    }
  });
}

int cmdStart(const Cli& cli) {
  return named(cli, "sat_start");
}
int cmdStop(const Cli& cli) {
  return named(cli, "sat_stop");
}
int cmdRestart(const Cli& cli) {
  return named(cli, "sat_restart");
}

int cmdLogs(const Cli& cli) {
  Args args(cli.args);
  const bool follow = args.flag("-f") || args.flag("--follow");
  const auto lines_opt = args.option("--lines");
  const auto rest = args.rest();
  if (rest.size() != 1 || !args.error().empty()) return usageError(cli);
  double lines = 100;
  if (lines_opt && !parseNumber(*lines_opt, "--lines", lines)) return kUsage;
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  int64_t after = 0;
  for (;;) {
    auto answer = sync->admin(
        "sat_logs",
        Variant::Map{{"name", rest[0]}, {"after", after}, {"lines", static_cast<int64_t>(lines)}});
    if (!answer) return fail(exitFor(answer.error()), "logs: " + answer.error().message);
    if (cli.json) {
      std::printf("%s\n", skr::flow::variantToJsonText(*answer).c_str());
      std::fflush(stdout);
    } else {
      printLines(*answer);
    }
    if (!follow) return kOk;
    if (const auto* m = answer->asMap(); m != nullptr && m->count("last") != 0) {
      if (auto last = m->at("last").asInt64()) after = *last;
    }
    lines = 2000;  // following: everything new
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
}

}  // namespace flowctl
