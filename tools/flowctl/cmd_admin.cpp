// flowctl flows, kick and chan rm: an administrator's commands (ADMIN, protocol 1.1;
// docs/security.md). Refused with exit 7 for an account that is not an administrator.
#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

// Runs one ADMIN command and prints its answer (JSON with --json, else `print`).
template <class Print>
int runAdmin(const Cli& cli, const std::string& command, const Variant& args, Print&& print) {
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto answer = sync->admin(command, args);
  if (!answer) return fail(exitFor(answer.error()), command + ": " + answer.error().message);
  if (cli.json) {
    std::printf("%s\n", skr::flow::variantToJsonText(*answer).c_str());
  } else {
    print(*answer);
  }
  return kOk;
}

std::string text(const Variant& map, const char* key) {
  const auto* m = map.asMap();
  if (m == nullptr) return {};
  auto it = m->find(key);
  if (it == m->end()) return {};
  if (const auto* s = it->second.asString()) return *s;
  return skr::flow::variantToJsonText(it->second);
}

}  // namespace

int cmdFlows(const Cli& cli) {
  Args args(cli.args);
  if (!args.rest().empty() || !args.error().empty()) return fail(kUsage, "usage: flowctl flows");
  return runAdmin(cli, "flows", Variant(), [](const Variant& answer) {
    std::printf("%-6s %-16s %-16s %-10s %-22s %5s %5s\n", "ID", "USER", "CLIENT", "TRANSPORT",
                "SOURCE", "CHANS", "SUBS");
    if (const auto* list = answer.asList()) {
      for (const auto& f : *list) {
        std::printf("%-6s %-16s %-16s %-10s %-22s %5s %5s\n", text(f, "id").c_str(),
                    text(f, "user").c_str(), text(f, "client").c_str(),
                    text(f, "transport").c_str(), text(f, "source").c_str(),
                    text(f, "channels").c_str(), text(f, "subscribed").c_str());
      }
    }
  });
}

int cmdKick(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (rest.size() != 1 || !args.error().empty()) return fail(kUsage, "usage: flowctl kick ID");
  double id = 0;
  if (!parseNumber(rest[0], "ID", id)) return kUsage;
  return runAdmin(
      cli, "kick", Variant::Map{{"connection", static_cast<int64_t>(id)}},
      [](const Variant& a) { std::printf("disconnected %s\n", text(a, "kicked").c_str()); });
}

int cmdChan(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (rest.size() != 2 || rest[0] != "rm" || !args.error().empty()) {
    return fail(kUsage, "usage: flowctl chan rm CHANNEL");
  }
  return runAdmin(cli, "chan_rm", Variant::Map{{"name", rest[1]}}, [](const Variant& a) {
    std::printf("removed %s\n", text(a, "removed").c_str());
  });
}

}  // namespace flowctl
