// SPDX-License-Identifier: Apache-2.0
// flowctl: reading the hub's statistics (hub_stats.h).
#include "hub_stats.h"

namespace flowctl::hubstats {

namespace {

const Variant kNull;

}  // namespace

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

}  // namespace flowctl::hubstats
