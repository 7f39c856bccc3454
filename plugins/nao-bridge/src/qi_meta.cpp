// SPDX-License-Identifier: Apache-2.0
#include "qi_meta.h"

namespace skr::nao::qi {

const char kMetaObjectSignature[] =
    "({I(Issss[(ss)<MetaMethodParameter,name,description>]s)<MetaMethod,uid,returnSignature,"
    "name,parametersSignature,description,parameters,returnDescription>}"
    "{I(Iss)<MetaSignal,uid,name,signature>}{I(Iss)<MetaProperty,uid,name,signature>}s)"
    "<MetaObject,methods,signals,properties,description>";

const char kServiceInfoSignature[] =
    "(sIsI[s]ss)<ServiceInfo,name,serviceId,machineId,processId,endpoints,sessionId,objectUid>";
const char kServiceInfoSignature6[] =
    "(sIsI[s]s)<ServiceInfo,name,serviceId,machineId,processId,endpoints,sessionId>";

namespace {

Error shape(const char* what) {
  return makeError(Errc::protocol_error, std::string("malformed ") + what);
}

bool isTuple(const Value& v, std::size_t n) {
  return v.kind() == Value::Kind::tuple && v.items().size() == n;
}

}  // namespace

const MetaMethod* MetaObject::resolve(const std::string& name,
                                      const std::vector<Value>& args) const {
  std::vector<Value> copy = args;
  const Value tuple = Value::tuple(std::move(copy));
  const std::string natural = toString(tuple.naturalType());
  const MetaMethod* convertible = nullptr;
  for (const MetaMethod& m : methods) {
    if (m.name != name) continue;
    auto t = parseSignature(m.parameters_signature);
    if (!t || t->kind != '(') continue;
    if (toString(t.value()) == natural) return &m;
    std::string scratch;
    if (convertible == nullptr && encode(t.value(), tuple, scratch)) convertible = &m;
  }
  return convertible;
}

Result<MetaObject> toMetaObject(const Value& v) {
  if (!isTuple(v, 4)) return shape("MetaObject");
  MetaObject m;
  for (const auto& [uid, method] : v.items()[0].entries()) {
    if (!isTuple(method, 7)) return shape("MetaMethod");
    const auto& f = method.items();
    m.methods.push_back(MetaMethod{static_cast<std::uint32_t>(uid.asInt()), f[1].asString(),
                                   f[2].asString(), f[3].asString()});
  }
  for (const auto& [uid, sig] : v.items()[1].entries()) {
    if (!isTuple(sig, 3)) return shape("MetaSignal");
    m.signals.emplace_back(static_cast<std::uint32_t>(uid.asInt()), sig.items()[1].asString());
  }
  m.description = v.items()[3].asString();
  return m;
}

Value fromMetaObject(const MetaObject& m) {
  std::vector<std::pair<Value, Value>> methods;
  for (const MetaMethod& x : m.methods) {
    methods.emplace_back(
        Value::integer(x.uid, 'I'),
        Value::tuple({Value::integer(x.uid, 'I'), Value::string(x.return_signature),
                      Value::string(x.name), Value::string(x.parameters_signature),
                      Value::string(""), Value::list({}), Value::string("")}));
  }
  std::vector<std::pair<Value, Value>> signals;
  for (const auto& [uid, name] : m.signals) {
    signals.emplace_back(
        Value::integer(uid, 'I'),
        Value::tuple({Value::integer(uid, 'I'), Value::string(name), Value::string("()")}));
  }
  return Value::tuple({Value::map(std::move(methods)), Value::map(std::move(signals)),
                       Value::map({}), Value::string(m.description)});
}

Result<ServiceInfo> toServiceInfo(const Value& v) {
  if (!isTuple(v, 6) && !isTuple(v, 7)) return shape("ServiceInfo");
  const auto& f = v.items();
  ServiceInfo s;
  s.name = f[0].asString();
  s.service_id = static_cast<std::uint32_t>(f[1].asInt());
  s.machine_id = f[2].asString();
  s.process_id = static_cast<std::uint32_t>(f[3].asInt());
  for (const Value& e : f[4].items()) s.endpoints.push_back(e.asString());
  s.session_id = f[5].asString();
  if (f.size() == 7) s.object_uid = f[6].asString();
  return s;
}

Value fromServiceInfo(const ServiceInfo& s, bool with_object_uid) {
  std::vector<Value> f = {Value::string(s.name),       Value::integer(s.service_id, 'I'),
                          Value::string(s.machine_id), Value::integer(s.process_id, 'I'),
                          Value::strings(s.endpoints), Value::string(s.session_id)};
  if (with_object_uid) f.push_back(Value::string(s.object_uid));
  return Value::tuple(std::move(f));
}

}  // namespace skr::nao::qi
