// SPDX-License-Identifier: Apache-2.0
// flowctl db: read and write PairDatabases on the synchronous connection.
#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

int cmdDb(const Cli& cli) {
  Args args(cli.args);
  const auto db = args.option("--db");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  const std::string op = rest.empty() ? "" : rest[0];
  const size_t want = op == "set" ? 3 : (op == "get" || op == "del") ? 2 : 1;
  const bool known = op == "get" || op == "set" || op == "del" || op == "ls" || op == "save" ||
                     op == "sync" || op == "databases";
  if (!known || rest.size() != want) return usageError(cli);
  std::optional<Variant> value;
  if (op == "set" && !(value = jsonArg(rest[2], "VALUE"))) return kUsage;
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  const std::string name = db ? *db : sync->login().user;
  if (op != "databases" && op != "sync") {
    if (auto s = sync->selectDatabase(name); !s) {
      return fail(exitFor(s.error()), "database " + name + ": " + s.error().message);
    }
  }
  const auto done = [&](const skr::Result<void>& r) {
    if (!r) return fail(exitFor(r.error()), r.error().message);
    if (cli.json) std::printf("{\"ok\":true}\n");
    return int(kOk);
  };
  if (op == "get") {
    auto v = sync->get(rest[1]);
    if (!v) return fail(exitFor(v.error()), v.error().message);
    std::printf("%s\n", skr::flow::variantToJsonText(*v).c_str());
    return kOk;
  }
  if (op == "set") return done(sync->set(rest[1], *value));
  if (op == "del") return done(sync->del(rest[1]));
  if (op == "save") return done(sync->saveDatabase(name));
  if (op == "sync") return done(sync->syncDatabases());
  if (op == "databases") {
    auto names = sync->databases();
    if (!names) return fail(exitFor(names.error()), names.error().message);
    Variant::List list(names->begin(), names->end());
    if (cli.json) return std::printf("%s\n", skr::flow::variantToJsonText(list).c_str()), kOk;
    for (const auto& n : *names) std::printf("%s\n", n.c_str());
    return kOk;
  }
  auto all = sync->getAll();  // ls
  if (!all) return fail(exitFor(all.error()), all.error().message);
  if (cli.json) return std::printf("%s\n", skr::flow::variantToJsonText(*all).c_str()), kOk;
  for (const auto& [key, v] : *all) {
    std::printf("%s = %s\n", key.c_str(), skr::flow::variantToJsonText(v).c_str());
  }
  return kOk;
}

}  // namespace flowctl
