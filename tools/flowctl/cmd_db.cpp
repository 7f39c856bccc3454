// SPDX-License-Identifier: Apache-2.0
// flowctl db: read and write PairDatabases on the synchronous connection; watch one on a flow.
#include "cli.h"
#include "session.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

// flowctl db watch: DB_WATCH on a flow; prints the pairs, then each change.
int watch(const Cli& cli, const std::optional<std::string>& db, double count) {
  using State = skr::flow::msg::DbPairState;
  Session s(cli, 100 * skr::kNsPerMs);
  uint64_t changes = 0;
  bool snapshot_done = false;
  std::string name;
  const auto print = [&](const sat::Satellite::DbPair& p) {
    static const char* const kStates[] = {"removed", "set", "cleared", "snapshot_end"};
    if (cli.json) {
      Variant::Map m{{"db", p.db}, {"key", p.key}, {"state", kStates[uint8_t(p.state)]}};
      if (p.state == State::set) m["value"] = p.value;
      std::printf("%s\n", skr::flow::variantToJsonText(Variant(std::move(m))).c_str());
    } else if (p.state == State::set) {
      std::printf("%s = %s\n", p.key.c_str(), skr::flow::variantToJsonText(p.value).c_str());
    } else if (p.state == State::removed) {
      std::printf("%s removed\n", p.key.c_str());
    } else if (p.state == State::cleared) {
      std::printf("(cleared)\n");
    } else if (!snapshot_done) {
      std::printf("(watching %s)\n", p.db.c_str());
    }
    std::fflush(stdout);
    if (p.state == State::snapshot_end) {
      snapshot_done = true;
    } else if (snapshot_done && count > 0 && ++changes >= static_cast<uint64_t>(count)) {
      s.end(kOk, {});
    }
  };
  s.satellite.error.connect(&s.satellite, [&](const sat::FlowError& e) {
    if (e.command != uint8_t(skr::flow::Code::db_watch)) return;
    const auto code = static_cast<skr::flow::ErrorCode>(e.error);
    s.end(exitFor({sat::toErrc(code), ""}), "database " + name + ": " + e.message);
  });
  s.satellite.connected.connect(&s.satellite, [&] {
    if (!name.empty()) return;
    name = db ? *db : s.satellite.user();
    if (auto r = s.satellite.watchDatabase(name, print); !r) {
      s.end(exitFor(r.error()), "database " + name + ": " + r.error().message);
    }
  });
  return s.run();
}

}  // namespace

int cmdDb(const Cli& cli) {
  Args args(cli.args);
  const auto db = args.option("--db");
  const auto count_text = args.option("--count");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  const std::string op = rest.empty() ? "" : rest[0];
  if (op == "watch") {
    if (rest.size() != 1) return usageError(cli);
    double count = 0;
    if (count_text && !parseNumber(*count_text, "--count", count)) return kUsage;
    return watch(cli, db, count);
  }
  if (count_text) return fail(kUsage, "--count is for db watch");
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
