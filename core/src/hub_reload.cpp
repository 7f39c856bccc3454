// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/hub_reload.h>

#include "families/admin/admin_args.h"

#include <skrobot/hub/flow/server.h>
#include <skrobot/hub/module_host.h>
#include <skrobot/hub/supervisor.h>
#include <skrobot/runtime/log.h>
#include <skrobot/support/json.hpp>

#include <map>
#include <set>

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

}  // namespace skr
