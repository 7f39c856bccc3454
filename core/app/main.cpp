// SPDX-License-Identifier: Apache-2.0
// skrobot: the hub executable. Loads the config, starts the modules on the main loop, then the
// supervised satellites, runs until SIGINT/SIGTERM, then stops the satellites and the modules in
// reverse order and exits 0.
#include <skrobot/hub/flow/hub_stats.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/hub/hub_config.h>
#include <skrobot/hub/hub_reload.h>
#include <skrobot/hub/install_layout.h>
#include <skrobot/hub/module_host.h>
#include <skrobot/hub/supervisor.h>
#include <skrobot/plugin.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/loop_handles.h>
#include <skrobot/support/json.hpp>

#include "user_command.h"

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace {

namespace fs = std::filesystem;

constexpr int kExitOk = 0;
constexpr int kExitCheckFailed = 1;
constexpr int kExitUsage = 2;
constexpr int kExitConfig = 3;
constexpr int kExitServer = 4;

constexpr const char* kUsage =
    "usage: skrobot [--config FILE] [--check-config | --list-modules | --describe-module NAME]\n"
    "               [--log-level LEVEL]\n"
    "       skrobot user add|del|passwd|list [NAME] [--users FILE] [--password-stdin]\n"
    "       skrobot --version | --help\n"
    "\n"
    "  --config FILE      the hub's JSON config (default: $SKROBOT_CONFIG when set, else\n"
    "                     the installed <prefix>/share/skrobot/default.json, else\n"
    "                     config/default.json of the current directory)\n"
    "  --check-config     validate the config, that every enabled module can be loaded and\n"
    "                     that its config object fits the keys the module declares (without\n"
    "                     starting it), that the TLS files can be loaded and that each\n"
    "                     satellite's program is there; exit 0 when all is well, 1 when a\n"
    "                     module would fail (MODULE-CONFIG lines name each bad key) or a\n"
    "                     program is missing, 3 on hub config errors (a bad TLS file included)\n"
    "  --list-modules     list the module files found on the search path\n"
    "  --describe-module NAME\n"
    "                     print the config keys a module declares (NAME or a path to a .so)\n"
    "  --log-level LEVEL  debug, info, warn or error (overrides the config)\n"
    "  --version          print the version\n"
    "  --help             print this help\n"
    "\n"
    "  user ...           manage the accounts of the users file (docs/accounts.md)\n"
    "\n"
    "SIGINT or SIGTERM stops the satellites (docs/robot.md), then the modules, in reverse\n"
    "order, and exits 0; a second signal stops at once. SIGHUP reads the config again and\n"
    "applies what changed (modules, satellites, log level; docs/robot.md).\n"
    "Config reference: docs/config.md; modules: docs/plugins.md.\n";

struct Options {
  fs::path config;
  bool check = false;
  bool list = false;
  std::string describe;  // --describe-module NAME
  std::string log_level;
};

// Every enabled module through the module host's own checks (file, descriptor, declared config
// keys), without initialising any.
int checkConfig(const skr::HubConfig& cfg) {
  if (cfg.server.tls) {
    // The files the hub would load at start: certificate, key (and that they match), client CA.
    auto tls = skr::flow::TlsContext::create(skr::flow::TlsRole::server, *cfg.server.tls);
    if (!tls) {
      std::fprintf(stderr, "skrobot: %s: server.tls: %s\n", cfg.config_file.c_str(),
                   tls.error().message.c_str());
      return kExitConfig;
    }
    std::printf("  %-20s ok  %s (client certificates %s)\n", "TLS",
                cfg.server.tls->cert_file.c_str(),
                tls->requiresPeerCertificate() ? "required" : "not asked for");
  }
  // Secrets the hub will read at start from its own environment (a link's password_env).
  for (const auto& n : cfg.notes) {
    std::printf("  %-20s needed  %s: %s\n", "environment", n.path.c_str(), n.reason.c_str());
  }
  int problems = 0;
  int missing = 0;  // satellites' programs
  // Each enabled satellite's program, found as the supervisor will (docs/robot.md).
  for (const skr::SatelliteEntry& sat : cfg.satellites) {
    if (!sat.enabled) {
      std::printf("  %-20s disabled (satellite)\n", sat.name.c_str());
      continue;
    }
    auto program = skr::findProgram(sat.command[0], skr::satellitePath(sat, skr::executableDir()));
    if (program) {
      std::printf("  %-20s ok  satellite %s\n", sat.name.c_str(), program->c_str());
    } else {
      ++missing;
      std::printf("  %-20s SATELLITE %s: %s\n", sat.name.c_str(), sat.json_path.c_str(),
                  program.error().message.c_str());
    }
  }
  const auto search = skr::moduleSearchPath(cfg.module_paths);
  size_t enabled = 0;
  for (const skr::ModuleCheck& c : skr::checkModules(cfg.modules, search)) {
    if (!c.enabled) {
      std::printf("  %-20s disabled\n", c.name.c_str());
      continue;
    }
    ++enabled;
    if (c.ok()) {
      std::printf("  %-20s ok  %s %s (ABI %u.%u)\n", c.name.c_str(), c.file.c_str(),
                  c.info.version.c_str(), c.info.abi_major, c.info.abi_minor);
      continue;
    }
    ++problems;
    if (!c.config_problems.empty()) {
      std::printf("  %-20s BAD CONFIG %s\n", c.name.c_str(), c.file.c_str());
      for (const auto& p : c.config_problems) {
        std::printf("    MODULE-CONFIG %s: %s\n", p.path.c_str(), p.reason.c_str());
      }
    } else {
      std::printf("  %-20s %s %s%s%s\n", c.name.c_str(), c.tag.c_str(), c.file.c_str(),
                  c.file.empty() ? "" : ": ", c.reason.c_str());
    }
  }
  if (problems > 0) {
    std::printf("config %s is valid, but %d of %zu enabled modules would fail to load\n",
                cfg.config_file.c_str(), problems, enabled);
    for (const auto& dir : search) std::printf("  searched: %s\n", dir.c_str());
  }
  if (missing > 0) {
    std::printf("config %s is valid, but %d satellites' programs are missing\n",
                cfg.config_file.c_str(), missing);
  }
  if (problems > 0 || missing > 0) return kExitCheckFailed;
  std::printf("config %s is valid; %zu enabled modules can be loaded\n", cfg.config_file.c_str(),
              enabled);
  return kExitOk;
}

// The config reference of one module: its declared keys, from its descriptor.
int describeModule(const std::string& name, const std::vector<fs::path>& config_paths) {
  skr::ModuleEntry entry;
  if (name.find('/') != std::string::npos) {
    entry.path = fs::absolute(name);
  } else {
    entry.name = name;
  }
  const auto search = skr::moduleSearchPath(config_paths);
  const auto checks = skr::checkModules({entry}, search);
  const skr::ModuleCheck& c = checks.front();
  if (!c.ok() && c.tag != "MODULE-CONFIG") {
    std::fprintf(stderr, "skrobot: %s %s: %s\n", name.c_str(), c.tag.c_str(), c.reason.c_str());
    return kExitCheckFailed;
  }
  const skr::ModuleFileInfo& info = c.info;
  std::printf("%s %s (ABI %u.%u) %s\n  %s\n", info.name.c_str(), info.version.c_str(),
              info.abi_major, info.abi_minor, c.file.c_str(), info.description.c_str());
  if (!info.declares_config) {
    std::printf("config: not declared (the module reads its config itself)\n");
    return kExitOk;
  }
  if (info.config_keys.empty()) std::printf("config: none (every key is an error)\n");
  for (const skr::ModuleConfigKey& k : info.config_keys) {
    std::string rules(skr::configTypeName(k.type));
    if (k.required) rules += ", required";
    if (!k.default_value.isNull()) rules += ", default " + skr::support::writeJson(k.default_value);
    const char* unit = k.type == skr::ConfigType::array ? " items" : "";
    if (k.min) rules += ", >= " + skr::schema::formatNumber(*k.min) + unit;
    if (k.max) rules += ", <= " + skr::schema::formatNumber(*k.max) + unit;
    if (k.non_empty) rules += ", not empty";
    for (size_t i = 0; i < k.choices.size(); ++i) {
      rules += (i == 0 ? ", one of " : "|") + k.choices[i];
    }
    std::printf("  %-18s %s\n  %-18s   %s\n", k.key.c_str(), rules.c_str(), "",
                k.description.c_str());
  }
  return kExitOk;
}

int listModules(const std::vector<fs::path>& config_paths) {
  const auto search = skr::moduleSearchPath(config_paths);
  size_t found = 0;
  for (const auto& item : skr::listModuleFiles(search)) {
    ++found;
    if (item.info) {
      std::printf("%-20s %-10s ABI %u.%u  %s\n    %s\n", item.info->name.c_str(),
                  item.info->version.c_str(), item.info->abi_major, item.info->abi_minor,
                  item.file.c_str(), item.info->description.c_str());
    } else {
      std::printf("%-20s unusable: %s\n    %s\n", item.file.stem().c_str(),
                  item.info.error().message.c_str(), item.file.c_str());
    }
  }
  if (found == 0) std::printf("no modules found\n");
  for (const auto& dir : search) std::printf("searched: %s\n", dir.c_str());
  return kExitOk;
}

skr::flow::ServerOptions serverOptions(const skr::HubConfig& cfg) {
  skr::flow::ServerOptions o;
  const skr::ServerConfig& s = cfg.server;
  o.app_name = cfg.app_name;
  o.unix_enabled = s.unix_enabled;
  o.unix_path = s.unix_path;
  o.tcp_enabled = s.tcp_enabled;
  o.tcp_address = s.tcp_address;
  o.tcp_port = s.tcp_port;
  o.tls = s.tls;
  o.serial = s.serial;
  o.udp = s.udp;
  o.web = s.web;
  o.max_frame_bytes = s.max_frame_bytes;
  o.subscriber_queue_bytes = s.subscriber_queue_bytes;
  o.subscriber_queue_max_bytes = s.subscriber_queue_max_bytes;
  o.max_connections = s.max_connections;
  o.login_timeout_ms = s.login_timeout_ms;
  o.max_pending_requests = s.max_pending_requests;
  o.request_timeout_ms = s.request_timeout_ms;
  o.user_limits = s.user_limits;
  o.data_dir = s.data_dir;
  o.durability = s.durability;
  o.compact_bytes = s.compact_bytes;
  o.blob_channel_bytes = s.blob_channel_bytes;
  o.blob_io_threads = s.blob_io_threads;
  o.blob_channel_files = s.blob_channel_files;
  o.users_file = s.users_file;
  o.dev_account = s.dev_account;
  o.hub_name = cfg.hub_name;
  o.links = cfg.links;
  o.link_hops = cfg.link_hops;
  o.replicas = cfg.replicas;
  return o;
}

// Where the supervisor finds skrobot-reaper, what it puts first in the satellites' PATH, and
// the secrets of the hub's environment that they do not get.
skr::SupervisorOptions supervisorOptions(const skr::HubConfig& cfg) {
  skr::SupervisorOptions o;
  o.bin_dir = skr::executableDir();
  o.reaper = o.bin_dir / "skrobot-reaper";
  for (const Json::Value& l : cfg.raw["links"]) {
    if (l.isObject() && l["password_env"].isString()) {
      o.hidden_env.push_back(l["password_env"].asString());
    }
  }
  return o;
}

int runHub(const skr::HubConfig& cfg, std::optional<skr::log::Level> fixed_level) {
  skr::Loop loop(cfg.loop);
  // SIGINT or SIGTERM: the satellites stop (each within its grace period), then the loop; a
  // second signal stops the loop at once (the reapers then kill what is left).
  skr::Supervisor* supervisor = nullptr;
  bool stopping = false;
  const auto on_signal = [&](int signum) {
    skr::log::info("hub", "HUB-SIGNAL",
                   std::string("received ") + strsignal(signum) + ", stopping");
    if (stopping || supervisor == nullptr) return loop.stop();
    stopping = true;
    supervisor->stopAll([&loop] { loop.stop(); });
  };
  skr::SignalWatch signals[2];
  for (int i = 0; i < 2; ++i) {
    auto w = skr::SignalWatch::open(loop, i == 0 ? SIGINT : SIGTERM, on_signal);
    if (w) signals[i] = std::move(w).value();
  }
  skr::log::info("hub", "HUB-START",
                 "skrobot " SKROBOT_VERSION " app " + cfg.app_name + ", config " +
                     cfg.config_file.string() + ", loop " +
                     std::string(skr::timingModeName(cfg.loop.mode)) + " " +
                     std::to_string(cfg.loop.fast_interval_ns / 1000) + " us / " +
                     std::to_string(cfg.loop.slow_interval_ns / 1000) + " us");
  skr::flow::FlowServer server(loop, serverOptions(cfg));
  if (auto started = server.start(); !started) {
    skr::log::error("hub", "HUB-SERVER",
                    "the FlowNetwork server cannot start: " + started.error().message);
    return kExitServer;
  }
  // The hub's statistics, hub.stats and hub.inspect (docs/observability.md).
  auto stats = std::make_unique<skr::flow::HubStats>(loop, server);
  // The hub's own sync source: a pulse on each of its fast ticks (docs/sync-pulse.md).
  std::unique_ptr<skr::flow::LocalClient> pulser;
  if (!cfg.sync_hub_source.empty()) {
    pulser = server.attachLocal("hub", "sync source", {});
    auto id = pulser->createChannel(cfg.sync_hub_source, skr::flow::ChannelKind::sync, "", {});
    if (!id) {
      skr::log::error("hub", "HUB-SYNC-SOURCE",
                      "hub." + cfg.sync_hub_source + ": " + id.error().message);
    } else {
      loop.addTickHandler(skr::Tick::fast, [&pulser, chan = *id] { (void)pulser->pulse(chan); });
    }
  }
  {
    skr::ModuleHost host(loop, cfg.module_paths, &server);
    host.start(cfg.modules);
    skr::log::info("hub", "HUB-READY",
                   std::to_string(host.modules().size()) + " modules running, " +
                       std::to_string(host.failures().size()) + " failed");
    {
      // The satellites start once the modules run, and stop before them.
      skr::Supervisor satellites(loop, server, cfg.satellites, supervisorOptions(cfg));
      stats->addSection("satellites", [&satellites] { return satellites.list(); });
      supervisor = &satellites;
      satellites.startAll();
      // SIGHUP or flowctl reload: the config read again, its changes applied (docs/robot.md).
      skr::Reloader reloader(loop, server, host, satellites, cfg, fixed_level);
      stats->addSection("modules", [&reloader] { return reloader.modules(); });
      auto hangup = skr::SignalWatch::open(loop, SIGHUP, [&reloader](int) {
        reloader.reload([](const skr::Result<std::vector<std::string>>&) {});  // it logs
      });
      loop.run();
      supervisor = nullptr;
      stats->removeSection("modules");
      stats->removeSection("satellites");
    }
    host.shutdown();
  }
  pulser.reset();
  stats.reset();
  server.stop();
  skr::log::info("hub", "HUB-STOP", "stopped");
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string_view(argv[1]) == "user") return runUserCommand(argc - 1, argv + 1);
  Options opt;
  bool config_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const auto value = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "skrobot: %s needs a value\n%s", argv[i], kUsage);
        std::exit(kExitUsage);
      }
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      std::fputs(kUsage, stdout);
      return kExitOk;
    } else if (arg == "--version") {
      std::printf("skrobot %s (plugin ABI %d.%d)\n", SKROBOT_VERSION, SKR_PLUGIN_ABI_MAJOR,
                  SKR_PLUGIN_ABI_MINOR);
      return kExitOk;
    } else if (arg == "--config") {
      opt.config = value();
      config_given = true;
    } else if (arg == "--check-config") {
      opt.check = true;
    } else if (arg == "--list-modules") {
      opt.list = true;
    } else if (arg == "--describe-module") {
      opt.describe = value();
    } else if (arg == "--log-level") {
      opt.log_level = value();
    } else {
      std::fprintf(stderr, "skrobot: unknown option '%s'\n%s", argv[i], kUsage);
      return kExitUsage;
    }
  }
  if (int(opt.check) + int(opt.list) + int(!opt.describe.empty()) > 1) {
    std::fprintf(stderr,
                 "skrobot: --check-config, --list-modules and --describe-module exclude each "
                 "other\n");
    return kExitUsage;
  }
  if (!config_given) opt.config = skr::defaultConfigFile();

  if (opt.list && !config_given && !fs::exists(opt.config)) return listModules({});
  if (!opt.describe.empty() && !config_given && !fs::exists(opt.config)) {
    return describeModule(opt.describe, {});
  }
  auto cfg = skr::loadHubConfig(opt.config,
                                opt.check ? skr::ConfigPurpose::check : skr::ConfigPurpose::start);
  if (!cfg) {
    std::fprintf(stderr, "skrobot: config error\n%s\n", cfg.error().message.c_str());
    return kExitConfig;
  }
  skr::log::setLevel(cfg->log_level);
  if (!opt.log_level.empty()) {
    skr::log::Level level{};
    if (!skr::log::parseLevel(opt.log_level, level)) {
      std::fprintf(stderr, "skrobot: --log-level must be debug, info, warn or error\n");
      return kExitUsage;
    }
    skr::log::setLevel(level);
  }
  if (opt.check) return checkConfig(*cfg);
  if (opt.list) return listModules(cfg->module_paths);
  if (!opt.describe.empty()) return describeModule(opt.describe, cfg->module_paths);
  std::optional<skr::log::Level> fixed_level;
  if (!opt.log_level.empty()) fixed_level = skr::log::Level{};
  if (fixed_level) skr::log::parseLevel(opt.log_level, *fixed_level);
  return runHub(*cfg, fixed_level);
}
