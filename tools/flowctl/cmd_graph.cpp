// SPDX-License-Identifier: Apache-2.0
// flowctl graph: who publishes and who subscribes, as Graphviz DOT (hub.inspect).
#include <map>

#include "hub_stats.h"

namespace flowctl {

using namespace hubstats;

namespace {

std::string dotId(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

int cmdGraph(const Cli& cli) {
  Args args(cli.args);
  const bool all = args.flag("--all");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (!rest.empty()) return usageError(cli);
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
