// SPDX-License-Identifier: Apache-2.0
// The "satellites" part of the config: processes the hub starts and supervises (docs/robot.md).
#pragma once

#include <skrobot/hub/hub_config.h>
#include <skrobot/hub/json_schema.h>

#include <json/value.h>

#include <filesystem>
#include <string_view>

namespace skr {

[[nodiscard]] schema::Schema satellitesSchema();
// Fills cfg.satellites from the document (defaults filled in); what is wrong goes to `problems`
// with its path: a name given twice, an `after` that names no satellite or makes a circle, a
// readiness by login without an account.
void readSatellites(const Json::Value& doc, const std::filesystem::path& base_dir, HubConfig& cfg,
                    schema::Problems& problems);

// The stop signals a satellite may name, and their numbers ("SIGTERM" -> 15); 0 when unknown.
[[nodiscard]] int stopSignalNumber(std::string_view name);

}  // namespace skr
