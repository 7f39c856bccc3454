// SPDX-License-Identifier: Apache-2.0
// The hub's configuration, loaded from JSON and validated before anything starts.
#pragma once

#include <skrobot/hub/flow/access.h>
#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/hub/json_schema.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/result.h>

#include <json/value.h>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skr {

// One entry of "modules": found by `name` on the module search path, or by `path`.
struct ModuleEntry {
  std::string name;            // module name; from the file name when only `path` is given
  std::filesystem::path path;  // resolved absolute path when given in the config, else empty
  bool enabled = true;
  bool own_thread = false;  // run on its own loop thread
  // The account whose rules and limits the module acts under (its channels stay
  // "<module>.<name>"): what it does for an outside party, a browser say, is checked as that
  // account. Empty: the default rules (docs/security.md).
  std::string account;
  LoopOptions loop;  // that thread's loop (inherits the hub's unless overridden)
  Json::Value config = Json::Value(Json::objectValue);  // the module's own object
  std::string json_path;  // where it stands in the config, e.g. "$.modules[2]"
};

// One entry of "satellites" (docs/robot.md): a process the hub starts, watches and restarts.
struct SatelliteEntry {
  enum class Restart { always, on_failure, never };
  std::string name;                  // [A-Za-z0-9_-]: its log source "sat.<name>"
  std::vector<std::string> command;  // program and arguments; a program with a '/' is resolved
                                     // against the config's directory, else looked up in PATH
  std::vector<std::pair<std::string, std::string>> env;  // added to the hub's environment
  std::filesystem::path cwd;  // resolved; default: the config file's directory
  std::string account;  // logs in as it (empty: as its own name, with the default rules), with
                        // a password made for each run
  Restart restart = Restart::on_failure;
  uint32_t backoff_ms = 1000;  // the first restart's delay, doubled at each failure
  uint32_t max_backoff_ms = 30000;
  uint32_t max_restarts_per_minute = 5;  // beyond it: failed, until started again
  std::vector<std::string> after;        // satellites that must be up, or channels ("u.c") that
                                         // must exist, before it starts
  std::string ready;                     // "started", "login" or a channel name
  uint32_t ready_timeout_ms = 30000;     // warned about once when readiness takes longer
  int stop_signal = 15;                  // SIGTERM
  uint32_t grace_ms = 5000;              // after the stop signal, SIGKILL
  uint64_t memory_bytes = 0;             // RLIMIT_DATA; 0: none
  uint32_t open_files = 0;               // RLIMIT_NOFILE; 0: the hub's
  int nice = 0;                          // added to the hub's niceness
  uint32_t log_lines_per_second = 100;   // into the hub's log; the rest counted, not logged
  bool enabled = true;
  std::string json_path;  // "$.satellites[N]"
};

// The FlowNetwork server, its databases and accounts ("server", "data_dir", "accounts").
struct ServerConfig {
  bool unix_enabled = true;
  std::string unix_path;  // empty: /tmp/<app_name>
  bool tcp_enabled = false;
  std::string tcp_address = "127.0.0.1";
  uint16_t tcp_port = 9000;
  std::optional<flow::TlsSettings> tls;                // "server.tls": the TCP listener speaks TLS
  std::vector<flow::transport::SerialOptions> serial;  // "server.serial": boards' ports
  std::optional<flow::transport::UdpOptions> udp;      // "server.udp": boards' UDP sessions
  std::optional<flow::WebOptions> web;                 // "server.web": the hub's web port
  uint32_t max_frame_bytes = 16u << 20;
  size_t subscriber_queue_bytes = 8u << 20;
  size_t subscriber_queue_max_bytes = 64u << 20;  // the cap of SUBSCRIBE_QUEUE's requests
  size_t max_connections = 1024;
  uint32_t login_timeout_ms = 5000;
  size_t max_pending_requests = 1024;
  uint32_t request_timeout_ms = 30000;
  flow::UserLimits user_limits{64, 1024, 64, 1024};  // per user, unless its account says otherwise
  std::filesystem::path data_dir;  // resolved; default $XDG_DATA_HOME/skrobot/<app_name>
  flow::Durability durability = flow::Durability::everysec;  // "databases.durability"
  uint64_t compact_bytes = 4u << 20;                         // "databases.compact_bytes"
  uint64_t blob_channel_bytes = 0;   // "blobs.max_channel_mib", in bytes; 0: no limit
  uint64_t blob_channel_files = 0;   // "blobs.max_channel_files"; 0: no limit
  uint32_t blob_io_threads = 1;      // "blobs.io_threads"
  std::filesystem::path users_file;  // resolved; default <data_dir>/users.json
  std::optional<std::pair<std::string, std::string>> dev_account;  // user, password
};

// What a config is loaded for. A start reads every secret it names (a link's password from its
// variable); a check (--check-config, `skrobot user`) runs in another shell than the hub's, so a
// variable it lacks is noted (HubConfig::notes), not refused.
enum class ConfigPurpose { start, check };

struct HubConfig {
  std::string app_name = "Robot";
  log::Level log_level = log::Level::info;
  LoopOptions loop;                                 // the main loop
  std::vector<std::filesystem::path> module_paths;  // searched before the built-in ones
  std::vector<ModuleEntry> modules;
  ServerConfig server;
  // Hub links (docs/hub-links.md): this hub's name (empty: the host's) and the hubs it links to,
  // each with its password read from its file or environment variable.
  std::string hub_name;
  std::vector<flow::HubLinkOptions> links;
  uint32_t link_hops = 8;  // a far channel that went through more links is not shown
  std::vector<flow::ReplicaOptions> replicas;  // "replicas": [{"from", "as"}]
  std::vector<SatelliteEntry> satellites;      // "satellites" (docs/robot.md)
  std::string sync_hub_source;  // "sync.hub_source": the hub pulses hub.<name> on its fast tick
  std::filesystem::path config_file;  // absolute path of the file loaded
  Json::Value raw;  // the whole document, with hubSchema()'s defaults filled in, for later sections
  // ConfigPurpose::check only: what the hub will need at start that this shell lacks.
  schema::Problems notes;
};

// Loads and validates a config file. On failure the error message lists every problem found,
// one per line, as "<file>: <json path>: <reason>" (or "<file>:<line>:<col>: <reason>" for
// JSON syntax errors). Relative paths in the file are resolved against its directory.
// The error code is Errc::config_error for a bad document, Errc::not_found or Errc::io_error
// when the file cannot be read.
[[nodiscard]] Result<HubConfig> loadHubConfig(const std::filesystem::path& file,
                                              ConfigPurpose purpose = ConfigPurpose::start);

// The same, from text already in memory; `origin` names it in messages and `base_dir` resolves
// relative paths.
[[nodiscard]] Result<HubConfig> parseHubConfig(std::string_view text, const std::string& origin,
                                               const std::filesystem::path& base_dir,
                                               ConfigPurpose purpose = ConfigPurpose::start);

// The schema of the whole document; adding a top-level section is one line in its definition.
// docs/config.md describes every key.
[[nodiscard]] schema::Schema hubSchema();

}  // namespace skr
