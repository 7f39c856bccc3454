// SPDX-License-Identifier: Apache-2.0
// The nats-bridge module's config (docs/fleet.md): the members the host checks from the declared
// keys (types, ranges) plus what it cannot: the items of "export", "import" and "kv".
#pragma once

#include "nats_client.h"

#include <skrobot/runtime/flow/name_pattern.h>

#include <json/value.h>

#include <cstdint>
#include <string>
#include <vector>

namespace skr::nats_bridge {

struct Import {
  std::string subject;  // may hold wildcards (not for a service)
  std::string as;       // the local channel's short name: "<module>.<as>"
  std::string mime = "application/octet-stream";
  bool service = false;    // a NATS subject callable as a local service channel
  int64_t timeout_ms = 0;  // service calls; 0: the bridge's request_timeout_ms
};

struct KvMirror {
  std::string db;      // a named PairDatabase of the hub
  std::string bucket;  // a JetStream key-value bucket
};

struct BridgeConfig {
  ClientOptions client;
  std::string prefix;  // subjects of exported channels; empty: "skrobot.<hub name>"
  flow::NameFilter exports;
  std::vector<Import> imports;
  std::vector<KvMirror> kv;
  std::string queue_group;  // for exported services: one of several hubs answers each request
  int64_t request_timeout_ms = 2000;
};

struct ConfigProblem {
  std::string key;  // below the module's "config": "import[1].as"
  std::string reason;
};

// Reads `config` (the module's config object, declared defaults filled in) into `out`; every
// problem found, not just the first.
[[nodiscard]] std::vector<ConfigProblem> readConfig(const Json::Value& config, BridgeConfig& out);

}  // namespace skr::nats_bridge
