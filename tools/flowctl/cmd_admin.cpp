// SPDX-License-Identifier: Apache-2.0
// flowctl flows, kick, chan rm, users, user, reload and module: an administrator's commands
// (ADMIN, protocol 1.1; docs/security.md). Refused with exit 7 for an account that is not an
// administrator.
#include <iostream>
#include <string>

#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

int cmdFlows(const Cli& cli) {
  Args args(cli.args);
  if (!args.rest().empty() || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, "flows", Variant(), [](const Variant& answer) {
    std::printf("%-6s %-16s %-16s %-10s %-22s %5s %5s\n", "ID", "USER", "CLIENT", "TRANSPORT",
                "SOURCE", "CHANS", "SUBS");
    if (const auto* list = answer.asList()) {
      for (const auto& f : *list) {
        std::printf("%-6s %-16s %-16s %-10s %-22s %5s %5s\n", field(f, "id").c_str(),
                    field(f, "user").c_str(), field(f, "client").c_str(),
                    field(f, "transport").c_str(), field(f, "source").c_str(),
                    field(f, "channels").c_str(), field(f, "subscribed").c_str());
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
      [](const Variant& a) { std::printf("disconnected %s\n", field(a, "kicked").c_str()); });
}

int cmdChan(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (rest.size() != 2 || rest[0] != "rm" || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, "chan_rm", Variant::Map{{"name", rest[1]}}, [](const Variant& a) {
    std::printf("removed %s\n", field(a, "removed").c_str());
  });
}

int cmdUsers(const Cli& cli) {
  Args args(cli.args);
  if (!args.rest().empty() || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, "users", Variant(), [](const Variant& answer) {
    if (const auto* list = answer.asList()) {
      for (const auto& u : *list) {
        std::printf("%-20s %-6s %s\n", field(u, "user").c_str(), field(u, "role").c_str(),
                    field(u, "created").c_str());
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
    std::printf("%s %s\n", field(answer, "done").c_str(), field(answer, "user").c_str());
  });
}

int cmdReload(const Cli& cli) {
  Args args(cli.args);
  if (!args.rest().empty() || !args.error().empty()) return usageError(cli);
  return runAdmin(cli, "reload", Variant(), [](const Variant& answer) {
    const auto* m = answer.asMap();
    if (m == nullptr || m->count("changes") == 0 || m->at("changes").asList() == nullptr) return;
    for (const auto& line : *m->at("changes").asList()) {
      if (line.asString() != nullptr) std::printf("%s\n", line.asString()->c_str());
    }
  });
}

namespace {

// flowctl module config NAME [KEY=VALUE...] [--save]: VALUE is JSON, else a string.
int moduleConfig(const Cli& cli, const std::string& name, const std::vector<std::string>& sets,
                 bool save) {
  Variant::Map a{{"name", name}};
  if (!sets.empty()) {
    Variant::Map set;
    for (const std::string& kv : sets) {
      const size_t eq = kv.find('=');
      if (eq == std::string::npos || eq == 0) return fail(kUsage, "expected KEY=VALUE, got " + kv);
      const std::string value = kv.substr(eq + 1);
      auto json = skr::flow::variantFromJsonText(value);
      set[kv.substr(0, eq)] = json ? *json : Variant(value);
    }
    a["set"] = Variant(std::move(set));
    a["save"] = save;
  } else if (save) {
    return usageError(cli);
  }
  return runAdmin(cli, "module_config", Variant(std::move(a)), [](const Variant& answer) {
    if (!field(answer, "applied").empty()) {
      std::printf(
          "%s %s%s\n", field(answer, "module").c_str(), field(answer, "applied").c_str(),
          field(answer, "saved").empty() ? "" : (", saved in " + field(answer, "saved")).c_str());
      return;
    }
    const auto* m = answer.asMap();
    if (m == nullptr || m->count("keys") == 0 || m->at("keys").asList() == nullptr) return;
    if (m->at("keys").asList()->empty()) std::printf("(it declares no keys)\n");
    // A member as JSON ("one" quoted), a number as a person writes it (1, not 1.0).
    const auto json = [](const Variant& map, const char* key) -> std::string {
      const auto* mm = map.asMap();
      if (mm == nullptr || mm->count(key) == 0) return {};
      const Variant& v = mm->at(key);
      if (auto d = v.asDouble(); d && *d == static_cast<double>(static_cast<int64_t>(*d))) {
        return std::to_string(static_cast<int64_t>(*d));
      }
      return skr::flow::variantToJsonText(v);
    };
    for (const auto& k : *m->at("keys").asList()) {
      std::string rules = field(k, "type");
      if (field(k, "required") == "true") rules += ", required";
      if (!json(k, "default").empty()) rules += ", default " + json(k, "default");
      if (!json(k, "min").empty()) rules += ", >= " + json(k, "min");
      if (!json(k, "max").empty()) rules += ", <= " + json(k, "max");
      if (!json(k, "choices").empty()) rules += ", one of " + json(k, "choices");
      std::printf("%-18s = %s\n  %-16s   %s; %s\n", field(k, "key").c_str(),
                  json(k, "value").c_str(), "", rules.c_str(), field(k, "description").c_str());
    }
  });
}

}  // namespace

int cmdModule(const Cli& cli) {
  Args args(cli.args);
  const auto config = args.option("--config");
  const bool save = args.flag("--save");
  const auto rest = args.rest();
  if (!args.error().empty() || rest.size() < 2) return usageError(cli);
  if (rest[0] == "config") {
    if (config) return usageError(cli);
    return moduleConfig(cli, rest[1], std::vector<std::string>(rest.begin() + 2, rest.end()), save);
  }
  if (rest.size() != 2 || (rest[0] != "load" && rest[0] != "unload") || save ||
      (config && rest[0] != "load")) {
    return usageError(cli);
  }
  Variant::Map a{{"name", rest[1]}};
  if (config) {
    auto value = jsonArg(*config, "--config");
    if (!value) return kUsage;
    a["config"] = std::move(*value);
  }
  return runAdmin(cli, "module_" + rest[0], Variant(std::move(a)), [](const Variant& answer) {
    if (!field(answer, "loaded").empty()) {
      std::printf("loaded %s (%s)\n", field(answer, "loaded").c_str(),
                  field(answer, "file").c_str());
    } else {
      std::printf("unloaded %s\n", field(answer, "unloaded").c_str());
    }
  });
}

}  // namespace flowctl
