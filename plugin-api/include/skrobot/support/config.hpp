// SPDX-License-Identifier: Apache-2.0
// Declaring a module's config keys (ABI 1.2) next to SKR_MODULE, header-only:
//
//   constexpr skr_config_key kConfig[] = {
//       skr::config::string("greeting", "hello", "logged with every EXAMPLE-TICK line"),
//       skr::config::integer("period_ms", "1000", "the EXAMPLE-TICK period").range(1, 3600000),
//       skr::config::string("input", nullptr, "the channel to read, <owner>.<name>").required(),
//       skr::config::string("method", "mog2", "background model").oneOf("mog2|knn|diff"),
//   };
//   SKR_MODULE_WITH_CONFIG(Example, "example", "1.0.0", "Tutorial", 0, kConfig)
//
// The host checks the config object against these keys before init (type, range, choices,
// required and unknown keys; each problem logged as "MODULE-CONFIG $.modules[N].config.<key>:
// <reason>"), and `skrobot --check-config` does so without starting the module. Declared
// defaults are filled in, so Host::configInt("period_ms") returns 1000 when the key is missing;
// the default argument of the getters only matters for undeclared keys.
//
// Defaults are text: the plain string for string keys, JSON for the other types ("1000",
// "0.5", "true", "[]"). The host refuses a module whose declaration is inconsistent (a default
// that is not JSON or breaks its own range, a key declared twice) with MODULE-DESCRIPTOR.
#pragma once

#include <skrobot/plugin.h>
#include <skrobot/plugin.hpp>

#include <cstddef>
#include <cstdint>

namespace skr::config {

// A skr_config_key under construction; converts to one implicitly.
class Key {
 public:
  constexpr Key(const char* key, skr_config_type type, const char* default_text,
                const char* description) noexcept
      : k_{key, type, 0, default_text, 0, 0, nullptr, description} {}

  constexpr Key min(double lo) const noexcept {
    Key out = *this;
    out.k_.min = lo;
    out.k_.flags |= SKR_CONFIG_MIN;
    return out;
  }
  constexpr Key max(double hi) const noexcept {
    Key out = *this;
    out.k_.max = hi;
    out.k_.flags |= SKR_CONFIG_MAX;
    return out;
  }
  constexpr Key range(double lo, double hi) const noexcept { return min(lo).max(hi); }
  // Must be present; give no default.
  constexpr Key required() const noexcept {
    Key out = *this;
    out.k_.flags |= SKR_CONFIG_REQUIRED;
    return out;
  }
  // A string that must not be "".
  constexpr Key nonEmpty() const noexcept {
    Key out = *this;
    out.k_.flags |= SKR_CONFIG_NON_EMPTY;
    return out;
  }
  // A string among `choices`, separated by '|': "mog2|knn|diff".
  constexpr Key oneOf(const char* choices) const noexcept {
    Key out = *this;
    out.k_.choices = choices;
    return out;
  }

  constexpr operator skr_config_key() const noexcept { return k_; }  // NOLINT

 private:
  skr_config_key k_;
};

constexpr Key string(const char* key, const char* default_value, const char* description) {
  return {key, SKR_CONFIG_STRING, default_value, description};
}
constexpr Key integer(const char* key, const char* default_json, const char* description) {
  return {key, SKR_CONFIG_INT, default_json, description};
}
constexpr Key number(const char* key, const char* default_json, const char* description) {
  return {key, SKR_CONFIG_DOUBLE, default_json, description};
}
constexpr Key boolean(const char* key, const char* default_json, const char* description) {
  return {key, SKR_CONFIG_BOOL, default_json, description};
}
// min/max bound the number of items.
constexpr Key array(const char* key, const char* default_json, const char* description) {
  return {key, SKR_CONFIG_ARRAY, default_json, description};
}
constexpr Key object(const char* key, const char* default_json, const char* description) {
  return {key, SKR_CONFIG_OBJECT, default_json, description};
}
// Any value but null; the module checks it (e.g. a device path or a camera index).
constexpr Key any(const char* key, const char* default_json, const char* description) {
  return {key, SKR_CONFIG_ANY, default_json, description};
}

}  // namespace skr::config

// SKR_MODULE with declared config keys: `keys` is a constexpr array of skr_config_key (at
// namespace scope). Use once per module, instead of SKR_MODULE.
#define SKR_MODULE_WITH_CONFIG(Class, name, version, description, flags, keys) \
  SKR_MODULE_DESCRIPTOR(Class, name, version, description, flags, (keys),      \
                        sizeof(keys) / sizeof((keys)[0]))

// Deprecated name (see plugin.hpp): this alias goes in the next minor release.
#define SKROBOT_MODULE_WITH_CONFIG(...)                                                           \
  _Pragma("GCC warning \"SKROBOT_MODULE_WITH_CONFIG is deprecated: use SKR_MODULE_WITH_CONFIG\"") \
      SKR_MODULE_WITH_CONFIG(__VA_ARGS__)
