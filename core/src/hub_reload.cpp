// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/hub_reload.h>

#include "families/admin/admin_args.h"

#include <skrobot/hub/config_edit.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/hub/module_host.h>
#include <skrobot/hub/supervisor.h>
#include <skrobot/runtime/log.h>
#include <skrobot/support/json.hpp>

#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace skr {

namespace {

// The satellites' entries by name, as written (defaults filled in): equal ones need nothing.
std::map<std::string, Json::Value> satellitesByName(const Json::Value& list) {
  std::map<std::string, Json::Value> out;
  for (const Json::Value& e : list) {
    if (e.isObject()) out[e["name"].asString()] = e;
  }
  return out;
}

// The enabled modules' entries by the name the host gives them (ModuleEntry::name, or the
// path's stem), as written.
std::map<std::string, Json::Value> modulesByName(const HubConfig& cfg) {
  std::map<std::string, Json::Value> out;
  for (size_t i = 0; i < cfg.modules.size(); ++i) {
    const ModuleEntry& m = cfg.modules[i];
    if (!m.enabled) continue;
    out[m.name] = cfg.raw["modules"][static_cast<Json::ArrayIndex>(i)];
  }
  return out;
}

}  // namespace

ReloadPlan planReload(const HubConfig& now, const HubConfig& next) {
  ReloadPlan plan;
  const auto before = modulesByName(now);
  const auto after = modulesByName(next);
  // Changed in its config alone: a candidate for the module's reconfigure step.
  const auto configOnly = [](Json::Value a, Json::Value b) {
    a.removeMember("config");
    b.removeMember("config");
    return a == b;
  };
  std::set<std::string> reconfigured;
  for (const auto& [name, entry] : before) {
    auto it = after.find(name);
    if (it == after.end()) {
      plan.unload.push_back(name);
    } else if (it->second != entry && configOnly(it->second, entry)) {
      reconfigured.insert(name);
    } else if (it->second != entry) {
      plan.unload.push_back(name);
      plan.restarted.push_back(name);
    }
  }
  for (const ModuleEntry& m : next.modules) {
    if (!m.enabled) continue;
    auto it = before.find(m.name);
    if (reconfigured.count(m.name) != 0) {
      plan.reconfigure.push_back(m);
    } else if (it == before.end() || it->second != after.at(m.name)) {
      plan.load.push_back(m);
    }
  }
  const auto sats_before = satellitesByName(now.raw["satellites"]);
  const auto sats_after = satellitesByName(next.raw["satellites"]);
  for (const auto& [name, entry] : sats_before) {
    if (sats_after.count(name) == 0) plan.satellites_removed.push_back(name);
  }
  for (const SatelliteEntry& s : next.satellites) {
    auto it = sats_before.find(s.name);
    if (it == sats_before.end()) {
      plan.satellites_added.push_back(s);
    } else if (it->second != sats_after.at(s.name)) {
      plan.satellites_changed.push_back(s);
    }
  }
  plan.log_level = now.log_level != next.log_level;
  // Everything else is read once, at start.
  const std::set<std::string> live{"modules", "satellites", "log"};
  std::set<std::string> keys;
  for (const auto& k : now.raw.getMemberNames()) keys.insert(k);
  for (const auto& k : next.raw.getMemberNames()) keys.insert(k);
  for (const auto& k : keys) {
    if (live.count(k) == 0 && now.raw[k] != next.raw[k]) plan.not_applied.push_back("$." + k);
  }
  return plan;
}

std::vector<std::string> describe(const ReloadPlan& plan) {
  std::vector<std::string> out;
  const std::set<std::string> restarted(plan.restarted.begin(), plan.restarted.end());
  for (const auto& n : plan.unload) {
    if (restarted.count(n) == 0) out.push_back("module removed: " + n);
  }
  for (const auto& m : plan.load) {
    out.push_back(
        (restarted.count(m.name) != 0 ? "module changed, restarted: " : "module added: ") + m.name);
  }
  for (const auto& n : plan.satellites_removed) out.push_back("satellite removed: " + n);
  for (const auto& s : plan.satellites_added) out.push_back("satellite added: " + s.name);
  for (const auto& s : plan.satellites_changed) {
    out.push_back("satellite changed, restarted: " + s.name);
  }
  if (plan.log_level) out.push_back("log level changed");
  for (const auto& k : plan.not_applied) {
    out.push_back(k + " changed: not applied, it takes a restart of the hub");
  }
  return out;
}

namespace {

constexpr std::string_view kLogSource = "hub";

// A module's declared keys, with their values in `config`, as ADMIN module_config answers.
flow::Variant keysOf(const ModuleHost::Settings& s) {
  flow::Variant::List keys;
  for (const ModuleConfigKey& k : s.info.config_keys) {
    flow::Variant::Map m{{"key", k.key},
                         {"type", std::string(configTypeName(k.type))},
                         {"required", k.required},
                         {"description", k.description}};
    if (auto d = flow::Variant::fromJson(k.default_value); d && !k.default_value.isNull()) {
      m["default"] = *d;
    }
    if (k.min) m["min"] = *k.min;
    if (k.max) m["max"] = *k.max;
    if (!k.choices.empty()) {
      flow::Variant::List choices;
      for (const auto& c : k.choices) choices.emplace_back(c);
      m["choices"] = flow::Variant(std::move(choices));
    }
    if (auto v = flow::Variant::fromJson(s.config[k.key]); v && s.config.isMember(k.key)) {
      m["value"] = *v;
    }
    keys.emplace_back(std::move(m));
  }
  return flow::Variant(std::move(keys));
}

// `text` written in place of `file`, atomically (a temporary beside it, renamed), with its mode.
Result<void> replaceFile(const std::filesystem::path& file, const std::string& text) {
  struct stat st {};
  const bool had = ::stat(file.c_str(), &st) == 0;
  const std::filesystem::path tmp = file.string() + ".saving";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) return makeError(Errc::io_error, "cannot write " + tmp.string());
  }
  if (had) ::chmod(tmp.c_str(), st.st_mode & 07777);
  if (std::rename(tmp.c_str(), file.c_str()) != 0) {
    return makeError(Errc::io_error, "cannot replace " + file.string());
  }
  return {};
}

}  // namespace

Reloader::Reloader(Loop& loop, flow::FlowServer& server, ModuleHost& modules,
                   Supervisor& satellites, HubConfig current, std::optional<log::Level> fixed_level)
    : loop_(loop),
      server_(server),
      modules_(modules),
      satellites_(satellites),
      current_(std::move(current)),
      fixed_level_(fixed_level) {
  server_.addAdminCommand(
      "reload", [this](const flow::Variant&, flow::FlowServer::AdminAnswer answer) {
        reload([answer = std::move(answer)](Result<std::vector<std::string>> r) {
          if (!r) return answer(r.error());
          flow::Variant::List lines;
          for (auto& l : *r) lines.emplace_back(std::move(l));
          answer(flow::Variant(flow::Variant::Map{{"changes", flow::Variant(std::move(lines))}}));
        });
      });
  server_.addAdminCommand(
      "module_load", [this](const flow::Variant& args, flow::FlowServer::AdminAnswer answer) {
        auto name = flow::adminString(args, "name");
        if (!name) return answer(name.error());
        Json::Value config;
        if (args.asMap()->count("config") != 0) config = args.asMap()->at("config").toJson();
        loadModule(*name, std::move(config),
                   [answer = std::move(answer), n = *name](Result<std::string> r) {
                     if (!r) return answer(r.error());
                     answer(flow::Variant(flow::Variant::Map{{"loaded", n}, {"file", *r}}));
                   });
      });
  server_.addAdminCommand(
      "module_config", [this](const flow::Variant& args, flow::FlowServer::AdminAnswer answer) {
        auto name = flow::adminString(args, "name");
        if (!name) return answer(name.error());
        const auto* m = args.asMap();
        const flow::Variant set = m->count("set") != 0 ? m->at("set") : flow::Variant();
        const bool save = m->count("save") != 0 && m->at("save").asBool().value_or(false);
        moduleConfig(*name, set, save, std::move(answer));
      });
  server_.addAdminCommand(
      "module_unload", [this](const flow::Variant& args, flow::FlowServer::AdminAnswer answer) {
        auto name = flow::adminString(args, "name");
        if (!name) return answer(name.error());
        if (!modules_.unload(*name)) {
          return answer(makeError(Errc::not_found, "no module " + *name + " runs"));
        }
        log::info(kLogSource, "HUB-MODULE-UNLOAD", *name);
        answer(flow::Variant(flow::Variant::Map{{"unloaded", *name}}));
      });
}

Reloader::~Reloader() {
  for (const char* c : {"reload", "module_load", "module_unload", "module_config"}) {
    server_.removeAdminCommand(c);
  }
  if (reader_.joinable()) reader_.join();
}

void Reloader::offLoop(std::function<std::function<void()>()> work) {
  busy_ = true;
  if (reader_.joinable()) reader_.join();  // the last one, long done
  reader_ = std::thread([this, alive = std::weak_ptr<int>(alive_), work = std::move(work)] {
    auto then = work();
    loop_.post([this, alive, then = std::move(then)] {
      if (alive.expired()) return;
      busy_ = false;
      then();
    });
  });
}

void Reloader::reload(Done done) {
  if (busy_) return done(makeError(Errc::limit_exceeded, "a reload is under way"));
  log::info(kLogSource, "HUB-RELOAD", "reading " + current_.config_file.string());
  // The file and the modules to load are read off the loop: disk and dlopen.
  offLoop([this, file = current_.config_file, now = current_, search = modules_.searchPath(),
           done = std::move(done)]() mutable -> std::function<void()> {
    Result<HubConfig> next = loadHubConfig(file);
    if (next) {
      const ReloadPlan plan = planReload(now, *next);
      std::vector<ModuleEntry> load = plan.load;
      load.insert(load.end(), plan.reconfigure.begin(), plan.reconfigure.end());
      std::string problems;
      for (const ModuleCheck& c : checkModules(load, search)) {
        if (c.ok() || !c.enabled) continue;
        if (!problems.empty()) problems += "\n";
        problems +=
            file.string() + ": " + c.json_path + ": " + c.tag + " " + c.name + ": " + c.reason;
      }
      if (!problems.empty()) next = makeError(Errc::module_failed, problems);
    }
    return [this, next = std::move(next), done = std::move(done)]() mutable {
      if (!next) {
        log::error(kLogSource, "HUB-RELOAD-REFUSED",
                   "nothing changed; the config has problems:\n" + next.error().message);
        return done(next.error());
      }
      apply(std::move(next).value(), std::move(done));
    };
  });
}

void Reloader::loadModule(const std::string& name, Json::Value config, ModuleDone done) {
  if (busy_) return done(makeError(Errc::limit_exceeded, "a reload is under way"));
  const bool plain = !name.empty() && name != "." && name != ".." &&
                     name.find_first_not_of(
                         "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                         "0123456789_.-") == std::string::npos;
  if (!plain) {
    return done(makeError(Errc::invalid_argument,
                          "a module is loaded by its name (A-Z a-z 0-9 _ . -), found on the "
                          "module search path, never by a path: \"" +
                              name + "\""));
  }
  for (const ModuleInfo& m : modules_.modules()) {
    if (m.name == name) return done(makeError(Errc::already_exists, "module " + name + " runs"));
  }
  ModuleEntry entry;
  entry.name = name;
  entry.config = config.isNull() ? Json::Value(Json::objectValue) : std::move(config);
  entry.json_path = "module load " + name;
  offLoop([this, entry, search = modules_.searchPath(),
           done = std::move(done)]() mutable -> std::function<void()> {
    ModuleCheck check = checkModules({entry}, search).front();
    return [this, entry = std::move(entry), check = std::move(check),
            done = std::move(done)]() mutable {
      if (!check.ok()) {
        return done(
            makeError(Errc::module_failed, check.tag + " " + entry.name + ": " + check.reason));
      }
      const size_t failed_before = modules_.failures().size();
      modules_.load({entry});
      modules_.initAll();
      modules_.startAll();
      if (modules_.failures().size() > failed_before) {
        const ModuleFailure& f = modules_.failures().back();
        return done(makeError(Errc::module_failed, f.tag + " " + f.name + ": " + f.reason));
      }
      log::info(kLogSource, "HUB-MODULE-LOAD", entry.name + " from " + check.file.string());
      done(check.file.string());
    };
  });
}

void Reloader::apply(HubConfig next, Done done) {
  ReloadPlan plan = planReload(current_, next);
  // Modules of the config that do not run now (they failed) are tried again.
  std::set<std::string> running;
  for (const ModuleInfo& m : modules_.modules()) running.insert(m.name);
  std::set<std::string> loading;
  for (const ModuleEntry& m : plan.load) loading.insert(m.name);
  std::erase_if(plan.reconfigure, [&](const ModuleEntry& m) { return running.count(m.name) == 0; });
  for (const ModuleEntry& m : next.modules) {
    if (m.enabled && running.count(m.name) == 0 && loading.count(m.name) == 0) {
      plan.load.push_back(m);
    }
  }
  std::vector<std::string> lines = describe(plan);
  for (const auto& name : plan.satellites_removed) satellites_.remove(name);
  for (auto& s : plan.satellites_changed) satellites_.replace(s);
  for (auto& s : plan.satellites_added) satellites_.add(s);
  // Changed in their config alone: in place when the module can, else restarted.
  for (const ModuleEntry& m : plan.reconfigure) {
    auto r = modules_.reconfigure(m);
    if (r) {
      lines.push_back("module reconfigured: " + m.name);
      continue;
    }
    lines.push_back("module changed, restarted: " + m.name + " (" + r.error().message + ")");
    plan.unload.push_back(m.name);
    plan.load.push_back(m);
  }
  for (const auto& name : plan.unload) modules_.unload(name);
  const size_t failed_before = modules_.failures().size();
  if (!plan.load.empty()) {
    modules_.load(plan.load);
    modules_.initAll();
    modules_.startAll();
  }
  for (size_t i = failed_before; i < modules_.failures().size(); ++i) {
    const ModuleFailure& f = modules_.failures()[i];
    lines.push_back("module " + f.name + " failed: " + f.tag + " " + f.reason);
  }
  if (plan.log_level && !fixed_level_) log::setLevel(next.log_level);
  current_ = std::move(next);
  if (lines.empty()) lines.emplace_back("nothing changed");
  for (const auto& l : lines) log::info(kLogSource, "HUB-RELOAD", l);
  done(std::move(lines));
}

void Reloader::moduleConfig(const std::string& name, const flow::Variant& set, bool save,
                            ConfigDone done) {
  auto now = modules_.settings(name);
  if (!now) return done(now.error());
  if (set.isNull()) {
    return done(flow::Variant(flow::Variant::Map{{"module", name}, {"keys", keysOf(*now)}}));
  }
  if (set.asMap() == nullptr || set.asMap()->empty()) {
    return done(makeError(Errc::invalid_argument, "\"set\" must be an object of keys and values"));
  }
  if (busy_) return done(makeError(Errc::limit_exceeded, "a reload is under way"));
  const Json::Value values = set.toJson();
  // The entry the config has for it (saved there, and the base of a restart), if any.
  ModuleEntry* from_config = nullptr;
  size_t index = 0;
  for (size_t i = 0; i < current_.modules.size(); ++i) {
    if (current_.modules[i].enabled && current_.modules[i].name == name) {
      from_config = &current_.modules[i];
      index = i;
    }
  }
  if (save && from_config == nullptr) {
    return done(makeError(Errc::invalid_argument,
                          name + " is not in the config file (flowctl module load): nothing to "
                                 "save it in"));
  }
  ModuleEntry entry;
  if (from_config != nullptr) {
    entry = *from_config;
  } else {
    entry.name = name;
    entry.json_path = "module config " + name;
  }
  Json::Value written = from_config != nullptr ? from_config->config : now->config;
  for (const std::string& key : values.getMemberNames()) written[key] = values[key];
  entry.config = written;
  std::string applied = "reconfigured";
  if (auto r = modules_.reconfigure(entry); !r) {
    if (r.error().code != Errc::unsupported) return done(r.error());  // nothing changed
    applied = "restarted";
    modules_.unload(name);
    const size_t failed_before = modules_.failures().size();
    modules_.load({entry});
    modules_.initAll();
    modules_.startAll();
    if (modules_.failures().size() > failed_before) {
      const ModuleFailure& f = modules_.failures().back();
      return done(makeError(Errc::module_failed, f.tag + " " + f.name + ": " + f.reason));
    }
  }
  log::info(kLogSource, "HUB-MODULE-CONFIG",
            name + " " + applied + ": " + support::writeJson(values) + (save ? ", saved" : ""));
  if (from_config != nullptr) {
    from_config->config = written;
    current_.raw["modules"][static_cast<Json::ArrayIndex>(index)]["config"] = written;
  }
  flow::Variant::Map answer{{"module", name}, {"applied", applied}};
  if (!save) return done(flow::Variant(std::move(answer)));
  // Written into the file off the loop: only these values, the rest as it is.
  offLoop([file = current_.config_file, index, values, answer = std::move(answer),
           done = std::move(done)]() mutable -> std::function<void()> {
    std::ifstream in(file, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    Result<void> saved = makeError(Errc::io_error, "cannot read " + file.string());
    if (in) {
      auto edited = editModuleConfig(text.str(), index, values);
      saved = edited ? replaceFile(file, *edited) : Result<void>(edited.error());
    }
    return [file, saved = std::move(saved), answer = std::move(answer),
            done = std::move(done)]() mutable {
      if (!saved) return done(saved.error());
      log::info(kLogSource, "HUB-CONFIG-SAVED", file.string());
      answer["saved"] = file.string();
      done(flow::Variant(std::move(answer)));
    };
  });
}

}  // namespace skr
