// SPDX-License-Identifier: Apache-2.0
// The structures the qi services describe themselves with: MetaObject (methods by name and
// action id) and ServiceInfo (what ServiceDirectory.service returns).
#pragma once

#include "qi_value.h"

#include <cstdint>
#include <string>
#include <vector>

namespace skr::nao::qi {

extern const char kMetaObjectSignature[];
// ServiceDirectory.service's answer: seven fields since libqi 4 (the object uid), six before.
extern const char kServiceInfoSignature[];
extern const char kServiceInfoSignature6[];

struct MetaMethod {
  std::uint32_t uid = 0;
  std::string return_signature;
  std::string name;
  std::string parameters_signature;  // a tuple, e.g. "(sf)"
};

struct MetaObject {
  std::vector<MetaMethod> methods;
  std::vector<std::pair<std::uint32_t, std::string>> signals;  // uid, name
  std::string description;

  // The overload of `name` whose parameters accept `args`: an exact match of their natural
  // types first, else the first one they convert to. nullptr when none does.
  [[nodiscard]] const MetaMethod* resolve(const std::string& name,
                                          const std::vector<Value>& args) const;
};

struct ServiceInfo {
  std::string name;
  std::uint32_t service_id = 0;
  std::string machine_id;
  std::uint32_t process_id = 0;
  std::vector<std::string> endpoints;
  std::string session_id;
  std::string object_uid;  // raw bytes (20 with libqi 4); empty from a six-field answer
};

[[nodiscard]] Result<MetaObject> toMetaObject(const Value& v);
[[nodiscard]] Value fromMetaObject(const MetaObject& m);
// Accepts the six- and the seven-field tuple.
[[nodiscard]] Result<ServiceInfo> toServiceInfo(const Value& v);
// The seven-field tuple, or the six-field one without the object uid.
[[nodiscard]] Value fromServiceInfo(const ServiceInfo& s, bool with_object_uid = true);

}  // namespace skr::nao::qi
