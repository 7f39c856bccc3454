// SPDX-License-Identifier: Apache-2.0
// flowctl flows, kick, chan rm, users and user: an administrator's commands (ADMIN, protocol
// 1.1; docs/security.md). Refused with exit 7 for an account that is not an administrator.
#include <iostream>
#include <string>

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
  if (!args.rest().empty() || !args.error().empty()) return usageError(cli);
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
  if (rest.size() != 1 || !args.error().empty()) return usageError(cli);
  double id = 0;
  if (!parseNumber(rest[0], "ID", id)) return kUsage;
  return runAdmin(
      cli, "kick", Variant::Map{{"connection", static_cast<int64_t>(id)}},
      [](const Variant& a) { std::printf("disconnected %s\n", text(a, "kicked").c_str()); });
}

int cmdChan(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (rest.size() != 2 || rest[0] != "rm" || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, "chan_rm", Variant::Map{{"name", rest[1]}}, [](const Variant& a) {
    std::printf("removed %s\n", text(a, "removed").c_str());
  });
}

int cmdUsers(const Cli& cli) {
  Args args(cli.args);
  if (!args.rest().empty() || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, "users", Variant(), [](const Variant& answer) {
    if (const auto* list = answer.asList()) {
      for (const auto& u : *list) {
        std::printf("%-20s %-6s %s\n", text(u, "user").c_str(), text(u, "role").c_str(),
                    text(u, "created").c_str());
      }
    }
  });
}

int cmdUser(const Cli& cli) {
  Args args(cli.args);
  const bool as_admin = args.flag("--admin");
  const auto rest = args.rest();
  if (!args.error().empty() || rest.size() < 2) return usageError(cli);
  const std::string& op = rest[0];
  Variant::Map a{{"user", rest[1]}};
  const auto password = [&a]() {
    std::string line;
    if (!std::getline(std::cin, line) || line.empty()) return false;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    a["password"] = line;
    return true;
  };
  if ((op == "add" || op == "passwd") && rest.size() == 2) {
    if (op == "add" && as_admin) a["role"] = "admin";
    if (!password()) return fail(kUsage, "no password on stdin (one line)");
  } else if (op == "del" && rest.size() == 2) {
  } else if (op == "role" && rest.size() == 3) {
    a["role"] = rest[2];
  } else if (op == "rule" && rest.size() >= 3) {
    a["action"] = rest[2];
    Variant::List patterns;
    for (size_t i = 3; i < rest.size(); ++i) patterns.emplace_back(rest[i]);
    a["patterns"] = Variant(std::move(patterns));
  } else {
    return usageError(cli);
  }
  return runAdmin(cli, "user_" + op, Variant(std::move(a)), [&](const Variant& answer) {
    std::printf("%s %s\n", text(answer, "done").c_str(), text(answer, "user").c_str());
  });
}

}  // namespace flowctl
