// SPDX-License-Identifier: Apache-2.0
// The Reloader's module commands (hub_reload.h): ADMIN module_load and module_config
// (flowctl module), and the "modules" section of hub.stats.
#include <skrobot/hub/config_edit.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/hub/hub_reload.h>
#include <skrobot/hub/module_host.h>
#include <skrobot/runtime/log.h>
#include <skrobot/support/json.hpp>

#include <sys/stat.h>

#include <fstream>
#include <set>
#include <sstream>

namespace skr {

namespace {

constexpr std::string_view kLogSource = "hub";

// Loads and starts one module; its failure (the MODULE-* tag and reason) as module_failed.
Result<void> startOne(ModuleHost& modules, const ModuleEntry& entry) {
  const size_t failed_before = modules.failures().size();
  modules.load({entry});
  modules.initAll();
  modules.startAll();
  if (modules.failures().size() > failed_before) {
    const ModuleFailure& f = modules.failures().back();
    return makeError(Errc::module_failed, f.tag + " " + f.name + ": " + f.reason);
  }
  return {};
}

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
      if (auto started = startOne(modules_, entry); !started) return done(started.error());
      log::info(kLogSource, "HUB-MODULE-LOAD", entry.name + " from " + check.file.string());
      done(check.file.string());
    };
  });
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
    if (auto started = startOne(modules_, entry); !started) return done(started.error());
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

flow::Variant Reloader::modules() const {
  flow::Variant::List list;
  std::set<std::string> shown;
  for (const ModuleInfo& m : modules_.modules()) {
    list.emplace_back(flow::Variant::Map{{"name", m.name},
                                         {"version", m.version},
                                         {"description", m.description},
                                         {"state", std::string(moduleStateName(m.state))},
                                         {"file", m.file.string()},
                                         {"settings", static_cast<uint64_t>(m.settings)}});
    shown.insert(m.name);
  }
  // The last failure of each module that does not run (the host keeps every one).
  const auto& failures = modules_.failures();
  for (auto f = failures.rbegin(); f != failures.rend(); ++f) {
    if (!shown.insert(f->name).second) continue;
    list.emplace_back(flow::Variant::Map{{"name", f->name},
                                         {"state", std::string("failed")},
                                         {"file", f->file.string()},
                                         {"reason", f->tag + ": " + f->reason}});
  }
  return flow::Variant(std::move(list));
}

}  // namespace skr
