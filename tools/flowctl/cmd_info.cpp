// SPDX-License-Identifier: Apache-2.0
// flowctl info: a channel's owner, subscribers, rate, totals, type and properties (hub.inspect).
#include <skrobot/channel_type.hpp>

#include <algorithm>
#include <map>

#include "hub_stats.h"
#include "mcap_mapping.h"

namespace flowctl {

using namespace hubstats;

namespace {

namespace ct = skr::channel_type;

// "cdr geometry_msgs/msg/Twist (ros2msg, 134-byte schema)", "opaque bytes", and what is wrong.
std::string describeType(const ct::ChannelType& t) {
  std::string d =
      t.message_encoding.empty() ? "opaque bytes (no message_encoding)" : t.message_encoding;
  if (!t.schema_name.empty()) {
    d += " " + t.schema_name + " (" + t.schema_encoding + ", " + std::to_string(t.schema.size()) +
         "-byte schema)";
  }
  if (auto bad = ct::check(t)) d += "; not a valid type: " + *bad;
  return d;
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

}  // namespace

int cmdInfo(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1) return usageError(cli);
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
  const ct::ChannelType type = mcapmap::typeOf(info->props);
  Variant::Map type_out{{"message_encoding", type.message_encoding},
                        {"schema_name", type.schema_name},
                        {"schema_encoding", type.schema_encoding}};
  if (auto bad = ct::check(type)) type_out.emplace("problem", *bad);
  out.asMap()->emplace("type", std::move(type_out));
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
  std::printf("  type         %s\n", describeType(type).c_str());
  // The schema's text is long: its size stands for it here (--json has it).
  Variant shown = info->props;
  if (shown.isMap() && !type.schema.empty()) {
    (*shown.asMap())[std::string(ct::kSchemaKey)] =
        "(" + std::to_string(type.schema.size()) + " bytes)";
  }
  std::printf("  properties   %s\n", skr::flow::variantToJsonText(shown).c_str());
  return kOk;
}

}  // namespace flowctl
