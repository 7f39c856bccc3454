// flowctl ls, call and db: requests on the synchronous connection.
#include <skrobot/flow/name_pattern.h>

#include <algorithm>

#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

// The linked hub a channel lives on ("arm" for "arm/guest.camera"), or "" for this hub's own.
std::string hubOf(const std::string& name) {
  const size_t slash = name.find('/');
  return slash == std::string::npos || slash > name.find('.') ? std::string()
                                                              : name.substr(0, slash);
}

Variant channelVariant(const skr::sat::ChannelInfo& c) {
  const auto kind = skr::flow::channelKindName(static_cast<skr::flow::ChannelKind>(c.kind));
  return Variant::Map{{"id", c.id},
                      {"hash", c.hash},
                      {"kind", std::string(kind)},
                      {"name", c.name},
                      {"hub", hubOf(c.name)},
                      {"owner", c.owner},
                      {"owner_connection", c.owner_connection},
                      {"mime", c.mime},
                      {"subscribers", c.subscribers},
                      {"props", c.props}};
}

// Parses a JSON value argument, or explains how to quote.
std::optional<Variant> jsonArg(const std::string& text, const char* what) {
  auto v = skr::flow::variantFromJsonText(text);
  if (v) return std::move(v).value();
  fail(kUsage,
       std::string(what) + " must be JSON (" + v.error().message + "); quote strings: '\"text\"'");
  return std::nullopt;
}

}  // namespace

int cmdLs(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  auto filter = skr::flow::NameFilter::parse(rest.empty() ? std::vector<std::string>{"**"} : rest);
  if (!filter) return fail(kUsage, filter.error().message);
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto list = sync->channels();
  if (!list) return fail(exitFor(list.error()), list.error().message);
  std::vector<skr::sat::ChannelInfo> shown;
  for (auto& c : *list) {
    if (filter->selects(c.name)) shown.push_back(std::move(c));
  }
  if (cli.json) {
    Variant::List out;
    for (const auto& c : shown) out.push_back(channelVariant(c));
    std::printf("%s\n", skr::flow::variantToJsonText(out).c_str());
    return kOk;
  }
  if (shown.empty()) {
    std::printf("no channels\n");
    return kOk;
  }
  size_t name_w = 4, owner_w = 5, mime_w = 4, hub_w = 3;
  for (const auto& c : shown) {
    name_w = std::max(name_w, c.name.size());
    hub_w = std::max(hub_w, hubOf(c.name).size());
    owner_w = std::max(owner_w, c.owner.size() + 1 + std::to_string(c.owner_connection).size());
    mime_w = std::max(mime_w, c.mime.size());
  }
  std::printf("%-5s %-9s %-*s %-*s %-*s %4s  %-*s  %s\n", "ID", "KIND", int(hub_w), "HUB",
              int(name_w), "NAME", int(owner_w), "OWNER", "SUBS", int(mime_w), "MIME",
              "PROPERTIES");
  for (const auto& c : shown) {
    const std::string owner = c.owner + "#" + std::to_string(c.owner_connection);
    const std::string hub = hubOf(c.name);
    std::printf("%-5u %-9s %-*s %-*s %-*s %4u  %-*s  %s\n", c.id,
                std::string(skr::flow::channelKindName(static_cast<skr::flow::ChannelKind>(c.kind)))
                    .c_str(),
                int(hub_w), hub.empty() ? "-" : hub.c_str(), int(name_w), c.name.c_str(),
                int(owner_w), owner.c_str(), c.subscribers, int(mime_w), c.mime.c_str(),
                skr::flow::variantToJsonText(c.props).c_str());
  }
  return kOk;
}

namespace {

// What an answer says went wrong, if it says so: services answer an object, by convention
// {"ok": true, ...} or {"ok": false, "error": "..."}, or {"error": "..."} (plugin_channels.hpp).
std::optional<std::string> failureIn(const Variant& answer) {
  const auto* map = answer.asMap();
  if (map == nullptr) return std::nullopt;
  std::optional<bool> ok;
  if (auto it = map->find("ok"); it != map->end()) ok = it->second.asBool();
  const std::string* error = nullptr;
  if (auto it = map->find("error"); it != map->end()) error = it->second.asString();
  const bool has_error = map->count("error") > 0;
  if (ok.value_or(!has_error)) return std::nullopt;
  if (error != nullptr) return *error;
  return std::string("the service answered that it failed");
}

}  // namespace

int cmdCall(const Cli& cli) {
  Args args(cli.args);
  const auto timeout = args.option("--timeout-ms");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() < 2 || rest.size() > 3)
    return fail(kUsage, "usage: flowctl call SERVICE CMD [VALUE]");
  double timeout_ms = 5000;
  if (timeout && !parseNumber(*timeout, "--timeout-ms", timeout_ms)) return kUsage;
  Variant value;
  if (rest.size() == 3) {
    auto v = jsonArg(rest[2], "VALUE");
    if (!v) return kUsage;
    value = std::move(*v);
  }
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto info = sync->channel(rest[0]);
  if (!info) return fail(exitFor(info.error()), "no such channel " + rest[0]);
  if (info->kind != static_cast<uint8_t>(skr::flow::ChannelKind::service)) {
    return fail(kFailed, rest[0] + " is not a service channel");
  }
  auto answer = sync->call(info->id, rest[1], value, static_cast<uint32_t>(timeout_ms));
  if (!answer) {
    const auto e = sync->lastError();
    if (e == skr::flow::ErrorCode::timeout || answer.error().code == skr::Errc::timeout) {
      return fail(kTimeout,
                  rest[0] + " did not answer within " + std::to_string(int(timeout_ms)) + " ms");
    }
    return fail(e == skr::flow::ErrorCode::owner_gone ? kFailed : exitFor(answer.error()),
                rest[0] + ": " + answer.error().message);
  }
  std::printf("%s\n", skr::flow::variantToJsonText(*answer).c_str());
  // The answer is printed either way; a script tells a refusal by the exit code.
  if (const auto why = failureIn(*answer)) return fail(kAnsweredFailure, rest[0] + ": " + *why);
  return kOk;
}

int cmdDb(const Cli& cli) {
  Args args(cli.args);
  const auto db = args.option("--db");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  const std::string op = rest.empty() ? "" : rest[0];
  const size_t want = op == "set" ? 3 : (op == "get" || op == "del") ? 2 : 1;
  const bool known = op == "get" || op == "set" || op == "del" || op == "ls" || op == "save" ||
                     op == "sync" || op == "databases";
  if (!known || rest.size() != want) return fail(kUsage, std::string(commandHelp("db")));
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
