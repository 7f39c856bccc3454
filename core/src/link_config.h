// SPDX-License-Identifier: Apache-2.0
// The hub-link part of the config: "hub_name" and "links" (docs/hub-links.md).
#pragma once

#include <skrobot/hub/hub_config.h>
#include <skrobot/hub/json_schema.h>

#include <json/value.h>

#include <filesystem>

namespace skr {

[[nodiscard]] schema::Schema hubNameSchema();
[[nodiscard]] schema::Schema linksSchema();
[[nodiscard]] schema::Schema linkHopsSchema();
[[nodiscard]] schema::Schema replicasSchema();
// Fills cfg.hub_name and cfg.links from the document (defaults filled in), reading each link's
// password from its file or environment variable; what is wrong goes to `problems` with its path.
// For a check, a variable that is not set goes to cfg.notes instead.
void readLinks(const Json::Value& doc, const std::filesystem::path& base_dir, ConfigPurpose purpose,
               HubConfig& cfg, schema::Problems& problems);

}  // namespace skr
