// SPDX-License-Identifier: Apache-2.0
// The arguments of an ADMIN command (a Variant map), read the same way by every part of the hub
// that answers one: the admin room, the supervisor of satellites, the reloader.
#pragma once

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <string>

namespace skr::flow {

// args[key] as a string; invalid_argument ("needs {"key": <string>}") when absent or not one.
inline Result<std::string> adminString(const Variant& args, const char* key) {
  if (const auto* m = args.asMap()) {
    if (auto it = m->find(key); it != m->end() && it->second.asString() != nullptr) {
      return *it->second.asString();
    }
  }
  return makeError(Errc::invalid_argument, std::string("needs {\"") + key + "\": <string>}");
}

// args[key] as an integer; invalid_argument when absent or not one.
inline Result<int64_t> adminInt(const Variant& args, const char* key) {
  if (const auto* m = args.asMap()) {
    if (auto it = m->find(key); it != m->end()) {
      if (auto n = it->second.asInt64()) return *n;
    }
  }
  return makeError(Errc::invalid_argument, std::string("needs {\"") + key + "\": <integer>}");
}

}  // namespace skr::flow
