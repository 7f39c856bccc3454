// SPDX-License-Identifier: Apache-2.0
// Declared config keys (ABI 1.2): reading them out of a module, and checking a config object
// against them with the hub's own schema validator (json_schema.h).
#include "module_record.h"

#include <skrobot/support/json.hpp>

#include <cmath>
#include <set>
#include <string>
#include <utility>

namespace skr {
namespace {

Result<ConfigType> configType(skr_config_type type) {
  switch (type) {
    case SKR_CONFIG_STRING:
      return ConfigType::string;
    case SKR_CONFIG_INT:
      return ConfigType::integer;
    case SKR_CONFIG_DOUBLE:
      return ConfigType::number;
    case SKR_CONFIG_BOOL:
      return ConfigType::boolean;
    case SKR_CONFIG_ARRAY:
      return ConfigType::array;
    case SKR_CONFIG_OBJECT:
      return ConfigType::object;
    case SKR_CONFIG_ANY:
      return ConfigType::any;
    default:
      break;
  }
  return makeError(Errc::parse_error, "unknown type " + std::to_string(static_cast<int>(type)));
}

std::vector<std::string> splitChoices(std::string_view text) {
  std::vector<std::string> out;
  while (true) {
    const std::size_t bar = text.find('|');
    out.emplace_back(text.substr(0, bar));
    if (bar == std::string_view::npos) return out;
    text.remove_prefix(bar + 1);
  }
}

schema::Schema keySchema(const ModuleConfigKey& k) {
  schema::Schema s;
  switch (k.type) {
    case ConfigType::string:
      s = schema::string();
      break;
    case ConfigType::integer:
      s = schema::integer();
      break;
    case ConfigType::number:
      s = schema::number();
      break;
    case ConfigType::boolean:
      s = schema::boolean();
      break;
    case ConfigType::any:
      s = schema::any();
      break;
    case ConfigType::object:
      s = schema::anyObject();
      break;
    case ConfigType::array:
      s.kind = schema::Kind::array;  // no element schema: elements are the module's to check
      if (k.min) s.min_items = static_cast<std::size_t>(std::max(0.0, std::ceil(*k.min)));
      if (k.max) s.max_items = static_cast<std::size_t>(std::max(0.0, std::floor(*k.max)));
      break;
  }
  if (k.type == ConfigType::integer || k.type == ConfigType::number) {
    if (k.min) s = s.atLeast(*k.min);
    if (k.max) s = s.atMost(*k.max);
  }
  if (k.non_empty) s = s.nonEmpty();
  if (!k.choices.empty()) s = s.oneOf(k.choices);
  return s;
}

}  // namespace

std::string_view configTypeName(ConfigType type) noexcept {
  switch (type) {
    case ConfigType::string:
      return "string";
    case ConfigType::integer:
      return "integer";
    case ConfigType::number:
      return "number";
    case ConfigType::boolean:
      return "boolean";
    case ConfigType::array:
      return "array";
    case ConfigType::object:
      return "object";
    case ConfigType::any:
      return "any";
  }
  return "?";
}

Result<std::vector<ModuleConfigKey>> readConfigKeys(const skr_config_key* keys, std::size_t count) {
  constexpr std::size_t kMaxKeys = 1024;  // a bound for a garbage count
  if (count > kMaxKeys) {
    return makeError(Errc::parse_error, "declares " + std::to_string(count) +
                                            " config keys, more than " + std::to_string(kMaxKeys));
  }
  std::vector<ModuleConfigKey> out;
  std::set<std::string, std::less<>> seen;
  for (std::size_t i = 0; i < count; ++i) {
    const skr_config_key& d = keys[i];
    const std::string where = "config key #" + std::to_string(i);
    if (d.key == nullptr || d.key[0] == '\0') {
      return makeError(Errc::parse_error, where + " has no name");
    }
    ModuleConfigKey k;
    k.key = d.key;
    const std::string named = "config key '" + k.key + "'";
    if (!seen.insert(k.key).second)
      return makeError(Errc::parse_error, named + " is declared twice");
    auto type = configType(d.type);
    if (!type) return makeError(Errc::parse_error, named + ": " + type.error().message);
    k.type = *type;
    k.required = (d.flags & SKR_CONFIG_REQUIRED) != 0;
    k.non_empty = (d.flags & SKR_CONFIG_NON_EMPTY) != 0;
    if ((d.flags & SKR_CONFIG_MIN) != 0) k.min = d.min;
    if ((d.flags & SKR_CONFIG_MAX) != 0) k.max = d.max;
    if ((k.min && !std::isfinite(*k.min)) || (k.max && !std::isfinite(*k.max)) ||
        (k.min && k.max && *k.min > *k.max)) {
      return makeError(Errc::parse_error, named + ": invalid bounds");
    }
    if (d.choices != nullptr) {
      if (k.type != ConfigType::string) {
        return makeError(Errc::parse_error, named + ": choices on a non-string key");
      }
      k.choices = splitChoices(d.choices);
    }
    if (d.default_text != nullptr) {
      if (k.required) return makeError(Errc::parse_error, named + ": required with a default");
      if (k.type == ConfigType::string) {
        k.default_value = Json::Value(d.default_text);
      } else {
        auto parsed = support::parseJson(d.default_text);
        if (!parsed) {
          return makeError(Errc::parse_error, named + ": default " + parsed.error().message);
        }
        k.default_value = std::move(parsed).value();
      }
      const schema::Problems p = schema::validate(k.default_value, keySchema(k), "default");
      if (!p.empty()) {
        return makeError(
            Errc::parse_error,
            named + ": default " + support::writeJson(k.default_value) + " " + p.front().reason);
      }
    }
    k.description = d.description != nullptr ? d.description : "";
    out.push_back(std::move(k));
  }
  return out;
}

schema::Schema moduleConfigSchema(const std::vector<ModuleConfigKey>& keys) {
  std::vector<schema::Field> fields;
  fields.reserve(keys.size());
  for (const ModuleConfigKey& k : keys) {
    fields.push_back(k.required ? schema::required(k.key, keySchema(k))
                                : schema::optional(k.key, keySchema(k), k.default_value));
  }
  return schema::object(std::move(fields));
}

schema::Problems checkModuleConfig(const ModuleFileInfo& info, const Json::Value& config,
                                   const std::string& path, Json::Value& filled) {
  if (!info.declares_config) {
    filled = config;
    return {};
  }
  const schema::Schema s = moduleConfigSchema(info.config_keys);
  schema::Problems problems = schema::validate(config, s, path);
  // The validator reports an unknown key at the object's path; name the key itself instead.
  if (config.isObject()) {
    for (const std::string& key : config.getMemberNames()) {
      const std::string prefix = "unknown key \"" + key + "\"";
      for (schema::Problem& p : problems) {
        if (p.path == path && p.reason.compare(0, prefix.size(), prefix) == 0) {
          p.path = schema::childPath(path, key);
          p.reason = "unknown key" + p.reason.substr(prefix.size());
        }
      }
    }
  }
  if (problems.empty()) filled = schema::withDefaults(config, s);
  return problems;
}

}  // namespace skr
