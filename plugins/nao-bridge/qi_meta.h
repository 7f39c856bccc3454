// The structures the qi services describe themselves with: MetaObject (methods by name and
// action id) and ServiceInfo (what ServiceDirectory.service returns).
#pragma once

#include "qi_value.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nao::qi {

extern const char kMetaObjectSignature[];
extern const char kServiceInfoSignature[];

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
};

[[nodiscard]] Result<MetaObject> toMetaObject(const Value& v);
[[nodiscard]] Value fromMetaObject(const MetaObject& m);
[[nodiscard]] Result<ServiceInfo> toServiceInfo(const Value& v);
[[nodiscard]] Value fromServiceInfo(const ServiceInfo& s);

}  // namespace nao::qi
