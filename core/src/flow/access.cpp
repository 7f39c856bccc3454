// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/flow/access.h>

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/log.h>

#include <array>
#include <mutex>

namespace skr::flow {

namespace {

constexpr std::array<std::string_view, 5> kActionNames = {"publish", "subscribe", "call", "db_read",
                                                          "db_write"};
constexpr std::array<std::string_view, 5> kActionVerbs = {"publish on", "subscribe to", "call",
                                                          "read database", "write database"};

int index(Action a) {
  return static_cast<int>(a);
}

}  // namespace

std::string_view actionName(Action action) noexcept {
  return kActionNames[index(action)];
}

UserLimits UserLimits::orElse(const UserLimits& d) const noexcept {
  const auto pick = [](uint32_t own, uint32_t def) { return own != 0 ? own : def; };
  return {pick(connections, d.connections), pick(channels, d.channels),
          pick(databases, d.databases),     pick(pending_requests, d.pending_requests),
          pick(blob_mib, d.blob_mib),       pick(blob_files, d.blob_files)};
}

namespace {

struct LimitField {
  const char* name;
  uint32_t UserLimits::*field;
};
constexpr LimitField kLimitFields[] = {
    {"connections", &UserLimits::connections}, {"channels", &UserLimits::channels},
    {"databases", &UserLimits::databases},     {"pending_requests", &UserLimits::pending_requests},
    {"blob_mib", &UserLimits::blob_mib},       {"blob_files", &UserLimits::blob_files}};

}  // namespace

uint32_t* UserLimits::field(std::string_view name) noexcept {
  for (const auto& lf : kLimitFields) {
    if (name == lf.name) return &(this->*(lf.field));
  }
  return nullptr;
}

AccessRules::AccessRules() {
  for (int i = 0; i < kActions; ++i) {
    (void)setRule(static_cast<Action>(i), {"**"});
  }
}

std::shared_ptr<const AccessRules> AccessRules::defaults() {
  static const auto d = std::shared_ptr<const AccessRules>(std::make_shared<AccessRules>());
  return d;
}

Result<void> AccessRules::setRule(Action action, std::vector<std::string> patterns) {
  auto filter = NameFilter::parse(patterns);
  if (!filter) {
    return makeError(Errc::invalid_argument,
                     std::string(actionName(action)) + ": " + filter.error().message);
  }
  filter_[index(action)] = std::move(filter.value());
  text_[index(action)] = std::move(patterns);
  return {};
}

Result<AccessRules> AccessRules::fromJson(const Json::Value& entry, const std::string& at) {
  AccessRules rules;
  const Json::Value& role = entry["role"];
  if (!role.isNull()) {
    if (role == "admin") {
      rules.role_ = Role::admin;
    } else if (role != "user") {
      return makeError(Errc::invalid_argument, at + ".role must be \"user\" or \"admin\"");
    }
  }
  const Json::Value& limits = entry["limits"];
  if (!limits.isNull()) {
    if (!limits.isObject())
      return makeError(Errc::invalid_argument, at + ".limits is not an object");
    for (const auto& key : limits.getMemberNames()) {
      const LimitField* f = nullptr;
      for (const auto& lf : kLimitFields) {
        if (key == lf.name) f = &lf;
      }
      const std::string path = at + ".limits." + key;
      if (f == nullptr) {
        return makeError(Errc::invalid_argument,
                         path +
                             ": unknown limit (connections, channels, databases, "
                             "pending_requests)");
      }
      const Json::Value& v = limits[key];
      if (!v.isUInt() || v.asUInt() == 0) {
        return makeError(Errc::invalid_argument, path + " must be a positive integer");
      }
      rules.limits_.*(f->field) = v.asUInt();
    }
  }
  const Json::Value& r = entry["rules"];
  if (r.isNull()) return rules;
  if (!r.isObject()) return makeError(Errc::invalid_argument, at + ".rules is not an object");
  for (const auto& key : r.getMemberNames()) {
    int found = -1;
    for (int i = 0; i < kActions; ++i) {
      if (key == kActionNames[i]) found = i;
    }
    const std::string path = at + ".rules." + key;
    if (found < 0) {
      return makeError(Errc::invalid_argument,
                       path + ": unknown rule (publish, subscribe, call, db_read, db_write)");
    }
    const Json::Value& list = r[key];
    if (!list.isArray()) return makeError(Errc::invalid_argument, path + " is not a list");
    std::vector<std::string> patterns;
    for (const auto& p : list) {
      if (!p.isString()) return makeError(Errc::invalid_argument, path + " holds a non-string");
      patterns.push_back(p.asString());
    }
    if (auto ok = rules.setRule(static_cast<Action>(found), std::move(patterns)); !ok) {
      return makeError(Errc::invalid_argument, path + ": " + ok.error().message);
    }
  }
  return rules;
}

void AccessRules::toJson(Json::Value& entry) const {
  entry.removeMember("role");
  entry.removeMember("rules");
  entry.removeMember("limits");
  Json::Value limits(Json::objectValue);
  for (const auto& lf : kLimitFields) {
    if (limits_.*(lf.field) != 0) limits[lf.name] = limits_.*(lf.field);
  }
  if (!limits.empty()) entry["limits"] = limits;
  if (role_ == Role::admin) entry["role"] = "admin";
  Json::Value rules(Json::objectValue);
  for (int i = 0; i < kActions; ++i) {
    if (text_[i] == std::vector<std::string>{"**"}) continue;
    Json::Value list(Json::arrayValue);
    for (const auto& p : text_[i]) list.append(p);
    rules[std::string(kActionNames[i])] = list;
  }
  if (!rules.empty()) entry["rules"] = rules;
}

bool AccessRules::allows(Action action, std::string_view name) const {
  return role_ == Role::admin || filter_[index(action)].selects(name);
}

const std::vector<std::string>& AccessRules::patterns(Action action) const {
  return text_[index(action)];
}

namespace {

// Refusals are logged, at most 20 lines a second (a client that insists cannot flood the log);
// the lines left out are counted in the next one.
void logRefusal(const char* tag, const std::string& message) {
  static std::mutex mutex;
  static Nanos window = 0;
  static int in_window = 0;
  static uint64_t suppressed = 0;
  std::lock_guard lock(mutex);
  const Nanos now = monotonicNs();
  if (now - window >= kNsPerSec) {
    window = now;
    in_window = 0;
  }
  if (++in_window > 20) {
    ++suppressed;
    return;
  }
  std::string line = message;
  if (suppressed > 0) line += " (" + std::to_string(suppressed) + " refusals not logged before)";
  suppressed = 0;
  log::warn("flow", tag, line);
}

}  // namespace

Error accessDenied(std::string_view user, Action action, std::string_view name) {
  Error e = makeError(Errc::permission_denied,
                      "user " + std::string(user) + " may not " +
                          std::string(kActionVerbs[index(action)]) + " " + std::string(name) +
                          " (its rules: " + std::string(actionName(action)) + ")");
  logRefusal("FLOW-DENIED", e.message);
  return e;
}

Error limitReached(std::string_view user, std::string_view what, uint32_t limit) {
  Error e = makeError(Errc::limit_exceeded, "user " + std::string(user) + " holds " +
                                                std::to_string(limit) + " " + std::string(what) +
                                                ", its limit (docs/security.md)");
  logRefusal("FLOW-LIMIT", e.message);
  return e;
}

}  // namespace skr::flow
