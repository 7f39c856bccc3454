// SPDX-License-Identifier: Apache-2.0
// flowctl link ls: the hub's links to other hubs, from their databases "_link.<name>".
#include "cli.h"

#include <skrobot/runtime/flow/variant.h>

namespace flowctl {

using skr::flow::Variant;

namespace {

std::string text(const Variant::Map& m, const char* key) {
  auto it = m.find(key);
  if (it == m.end()) return "-";
  if (const auto* s = it->second.asString()) return *s;
  if (const auto d = it->second.asDouble()) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.0f", *d);
    return buf;
  }
  return skr::flow::variantToJsonText(it->second);
}

}  // namespace

int cmdLink(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1 || rest[0] != "ls") return usageError(cli);
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto names = sync->databases();
  if (!names) return fail(exitFor(names.error()), names.error().message);
  Variant::List links;
  for (const std::string& name : *names) {
    if (!name.starts_with("_link.")) continue;
    if (auto r = sync->selectDatabase(name); !r) return fail(exitFor(r.error()), r.error().message);
    auto all = sync->getAll();
    if (!all) return fail(exitFor(all.error()), all.error().message);
    links.emplace_back(std::move(all).value());
  }
  if (cli.json) {
    std::printf("%s\n", skr::flow::variantToJsonText(Variant(links)).c_str());
    return kOk;
  }
  if (links.empty()) {
    std::printf("no links\n");
    return kOk;
  }
  std::printf("%-16s %-24s %-9s %8s %10s %12s %10s %8s  %s\n", "HUB", "STATE", "CHANNELS", "RTT_US",
              "OFFSET_US", "MESSAGES_IN", "REQUESTS", "DROPPED", "ADDRESS");
  for (const Variant& l : links) {
    const Variant::Map& m = *l.asMap();
    std::printf("%-16s %-24s %-9s %8s %10s %12s %10s %8s  %s\n", text(m, "hub").c_str(),
                text(m, "state").substr(0, 24).c_str(), text(m, "channels").c_str(),
                text(m, "round_trip_us").c_str(), text(m, "clock_offset_us").c_str(),
                text(m, "messages_in").c_str(), text(m, "requests").c_str(),
                text(m, "dropped").c_str(), text(m, "address").c_str());
  }
  return kOk;
}

}  // namespace flowctl
