// SPDX-License-Identifier: Apache-2.0
// Who may do what: a user's role and rules, from the users file (docs/security.md).
//
//   "alice": {"hash": "...", "role": "user",
//             "rules": {"publish": ["alice.**"], "subscribe": ["**", "!bob.secret"],
//                       "call": ["speech.*"], "db_read": ["**"], "db_write": ["alice*"]}}
//
// Each rule is a list of channel-name patterns
// (runtime/include/skrobot/runtime/flow/name_pattern.h, the one pattern syntax) naming what the
// user may do: publish (create and publish on its own channels), subscribe, call (service
// channels), read databases (select them) and write them. A rule left out is ["**"]: a user without
// rules keeps what every logged-in user could do before rules existed. Ownership still applies on
// top: a user writes only named databases and its own user, flow and channel databases. An
// administrator ("role": "admin") may do everything, including removing any channel and writing any
// database. The development account and the hub's modules have the defaults.
#pragma once

#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/result.hpp>

#include <json/value.h>

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace skr::flow {

enum class Role { user, admin };

// What one user may hold at once, across all its connections. In the users file an account may
// set its own ("limits": {"connections": 8}); a limit it leaves out (0 here) is the hub's
// (server.user_limits in the config). The blob issue adds its byte and file quotas here.
struct UserLimits {
  uint32_t connections = 0;       // logged-in connections
  uint32_t channels = 0;          // channels it owns
  uint32_t databases = 0;         // named databases it created (since the hub started)
  uint32_t pending_requests = 0;  // its service requests not answered yet
  uint32_t blob_mib = 0;          // MiB its blob channels hold together (uploads under way too)
  uint32_t blob_files = 0;        // files its blob channels hold together
  // Each limit of `this`, or of `defaults` where this one is 0. A blob limit of 0 in the result
  // is no limit.
  [[nodiscard]] UserLimits orElse(const UserLimits& defaults) const noexcept;
  // The limit named `name` as the users file names it ("connections", ..., "blob_files"), or
  // nullptr; kNames lists them.
  [[nodiscard]] uint32_t* field(std::string_view name) noexcept;
  static constexpr const char* kNames =
      "connections, channels, databases, pending_requests, blob_mib, blob_files";
};

// What one action needs; the rule of the same name decides.
enum class Action { publish, subscribe, call, db_read, db_write };

[[nodiscard]] std::string_view actionName(Action action) noexcept;

class AccessRules {
 public:
  // A user without rules: every rule is ["**"].
  AccessRules();
  // Every rule "**", no administrator role: users without rules, the development account, the
  // hub's modules.
  [[nodiscard]] static std::shared_ptr<const AccessRules> defaults();

  // From a users file entry ("role", "rules", "limits"); errors name `at` (e.g.
  // "users.alice.rules.call").
  [[nodiscard]] static Result<AccessRules> fromJson(const Json::Value& entry,
                                                    const std::string& at);
  // Writes "role", "rules" and "limits" into a users file entry, leaving out the defaults.
  void toJson(Json::Value& entry) const;

  [[nodiscard]] bool admin() const noexcept { return role_ == Role::admin; }
  [[nodiscard]] Role role() const noexcept { return role_; }
  // True when the rule for `action` selects `name` (a channel or database name); always for an
  // administrator.
  [[nodiscard]] bool allows(Action action, std::string_view name) const;
  // The patterns of a rule as written (["**"] when left out).
  [[nodiscard]] const std::vector<std::string>& patterns(Action action) const;

  void setRole(Role role) noexcept { role_ = role; }
  // The account's own limits (0: the hub's).
  [[nodiscard]] const UserLimits& limits() const noexcept { return limits_; }
  void setLimits(const UserLimits& limits) noexcept { limits_ = limits; }
  // Errc::invalid_argument naming the bad pattern.
  [[nodiscard]] Result<void> setRule(Action action, std::vector<std::string> patterns);

 private:
  static constexpr int kActions = 5;
  Role role_ = Role::user;
  UserLimits limits_;
  std::vector<std::string> text_[kActions];
  NameFilter filter_[kActions];
};

// Errc::permission_denied: "user alice may not subscribe to bob.secret (rules: ...)".
[[nodiscard]] Error accessDenied(std::string_view user, Action action, std::string_view name);
// Errc::limit_exceeded: "user alice holds 8 channels, its limit".
[[nodiscard]] Error limitReached(std::string_view user, std::string_view what, uint32_t limit);

}  // namespace skr::flow
