// SPDX-License-Identifier: Apache-2.0
// ADMIN (protocol 1.1): what an administrator does over the protocol (docs/security.md).
//   flows                        -> [{id, user, client, transport, source, channels, subscribed}]
//   kick    {"connection": N}    -> {"kicked": "<connection N (...)>"}: closes that connection
//   chan_rm {"name": "u.c"}      -> {"removed": "u.c"}: removes any channel
//   db_rm   {"name": "db"}       -> {"removed": "db"}: removes a named database
// and the accounts of the users file, changed on the authenticator's worker thread (argon2id and
// the file's save stay off the loop) while the connection waits:
//   users                                      -> [{user, role, created}]
//   user_add    {"user", "password", "role"?}  user_del {"user"}  user_passwd {"user", "password"}
//   user_role   {"user", "role"}               user_rule {"user", "action", "patterns": [...]}
#include "families/admin/admin_room.h"

#include "families/admin/admin_args.h"

#include "connection.h"
#include "hub.h"

#include <skrobot/runtime/log.h>

namespace skr::flow {

namespace {

// The change a user_* command makes to the users file; invalid_argument for bad arguments.
Result<Authenticator::Change> userChange(const std::string& command, const Variant& args) {
  auto user = adminString(args, "user");
  if (!user) return user.error();
  const std::string u = *user;
  if (command == "user_del") {
    return Authenticator::Change([u](UsersFile& f) { return f.remove(u); });
  }
  if (command == "user_add" || command == "user_passwd") {
    auto password = adminString(args, "password");
    if (!password) return password.error();
    Role role = Role::user;
    if (command == "user_add" && args.asMap() != nullptr && args.asMap()->count("role") != 0) {
      auto r = adminString(args, "role");
      if (!r || (*r != "admin" && *r != "user")) {
        return makeError(Errc::invalid_argument, "role must be \"admin\" or \"user\"");
      }
      role = *r == "admin" ? Role::admin : Role::user;
    }
    if (command == "user_passwd") {
      return Authenticator::Change(
          [u, p = *password](UsersFile& f) { return f.setPassword(u, p); });
    }
    return Authenticator::Change([u, p = *password, role](UsersFile& f) -> Result<void> {
      if (auto added = f.add(u, p); !added) return added;
      AccessRules access;
      access.setRole(role);
      return f.setAccess(u, access);
    });
  }
  if (command == "user_role") {
    auto r = adminString(args, "role");
    if (!r || (*r != "admin" && *r != "user")) {
      return makeError(Errc::invalid_argument, "needs {\"role\": \"admin\" | \"user\"}");
    }
    const Role role = *r == "admin" ? Role::admin : Role::user;
    return Authenticator::Change([u, role](UsersFile& f) -> Result<void> {
      if (!f.contains(u)) return makeError(Errc::not_found, "no user " + u);
      AccessRules access = *f.accessOf(u);
      access.setRole(role);
      return f.setAccess(u, access);
    });
  }
  if (command == "user_rule") {
    auto action_name = adminString(args, "action");
    if (!action_name) return action_name.error();
    std::optional<Action> action;
    for (auto a :
         {Action::publish, Action::subscribe, Action::call, Action::db_read, Action::db_write}) {
      if (actionName(a) == *action_name) action = a;
    }
    if (!action) return makeError(Errc::invalid_argument, "unknown action " + *action_name);
    std::vector<std::string> patterns;
    const auto* map = args.asMap();
    const auto it = map->find("patterns");
    if (it != map->end() && it->second.asList() != nullptr) {
      for (const auto& p : *it->second.asList()) {
        if (p.asString() == nullptr) {
          return makeError(Errc::invalid_argument, "patterns must be strings");
        }
        patterns.push_back(*p.asString());
      }
    }
    if (patterns.empty()) patterns.emplace_back("**");
    AccessRules check;
    if (auto ok = check.setRule(*action, patterns); !ok) return ok.error();  // refused here
    return Authenticator::Change([u, a = *action, patterns](UsersFile& f) -> Result<void> {
      if (!f.contains(u)) return makeError(Errc::not_found, "no user " + u);
      AccessRules access = *f.accessOf(u);
      if (auto ok = access.setRule(a, patterns); !ok) return ok;
      return f.setAccess(u, access);
    });
  }
  return makeError(Errc::invalid_argument, "ADMIN: unknown command \"" + command + "\"");
}

}  // namespace

void AdminRoom::handle(Connection& c, msg::Admin& m) {
  if (m.command == "users" || m.command.rfind("user_", 0) == 0) return users(c, m.command, m.args);
  if (auto it = more.find(m.command); it != more.end()) {
    if (!c.access->admin()) {
      c.replyError(ErrorCode::permission_denied,
                   "ADMIN " + m.command + ": user " + c.user + " is not an administrator");
      return;
    }
    log::info(kLogSource, "FLOW-ADMIN",
              c.describe() + ": " + m.command + " " + variantToJsonText(m.args));
    c.block();              // answered when the command is done
    auto run = it->second;  // the command may remove itself
    run(m.args, c.whenRead([](Connection& c, Result<Variant> r) {
      if (r) {
        c.send(msg::ReplyValue{std::move(r).value()});
      } else {
        c.reply(r.error());
      }
      c.unblock();
    }));
    return;
  }
  auto r = command(c, m.command, m.args);
  if (!r) return c.reply(r.error());
  c.send(msg::ReplyValue{std::move(r).value()});
}

void AdminRoom::users(Connection& c, const std::string& command, const Variant& args) {
  if (!c.access->admin()) {
    c.replyError(ErrorCode::permission_denied,
                 "ADMIN " + command + ": user " + c.user + " is not an administrator");
    return;
  }
  Authenticator& auth = *hub_.session.auth;
  if (command == "users") {
    const UsersFile file = auth.snapshot();
    Variant::List out;
    for (const auto& name : file.names()) {
      out.push_back(Variant::Map{{"user", name},
                                 {"role", file.accessOf(name)->admin() ? "admin" : "user"},
                                 {"created", file.createdOf(name).value_or("")}});
    }
    c.send(msg::ReplyValue{Variant(std::move(out))});
    return;
  }
  auto change = userChange(command, args);
  if (!change) return c.reply(change.error());
  const std::string target = *adminString(args, "user");
  log::info(kLogSource, "FLOW-ADMIN", c.describe() + ": " + command + " " + target);
  c.block();  // answered when the worker is done
  auth.changeUsers(std::move(change).value(), c.whenDone([command, target](Connection& c,
                                                                           const Result<void>& r) {
    if (r) {
      c.send(msg::ReplyValue{Variant(Variant::Map{{"done", command}, {"user", target}})});
    } else {
      c.reply(r);
    }
    c.unblock();
  }));
}

Result<Variant> AdminRoom::command(Connection& by, const std::string& command,
                                   const Variant& args) {
  if (!by.access->admin()) {
    return makeError(Errc::permission_denied,
                     "ADMIN " + command + ": user " + by.user + " is not an administrator");
  }
  log::info(kLogSource, "FLOW-ADMIN",
            by.describe() + ": " + command + " " + variantToJsonText(args));
  if (command == "flows") {
    Variant::List out;
    for (const auto& [id, c] : hub_.connections) {
      if (c->user.empty()) continue;  // not logged in
      out.push_back(Variant::Map{{"id", static_cast<int64_t>(id)},
                                 {"user", c->user},
                                 {"client", c->client_name},
                                 {"transport", std::string(transportName(c->transport()))},
                                 {"source", c->source},
                                 {"flow", c->receivesEvents()},
                                 {"channels", static_cast<int64_t>(c->owned.size())},
                                 {"subscribed", static_cast<int64_t>(c->subscribed.size())}});
    }
    return Variant(std::move(out));
  }
  if (command == "kick") {
    auto id = adminInt(args, "connection");
    if (!id) return id.error();
    auto it = hub_.connections.find(static_cast<uint32_t>(*id));
    if (it == hub_.connections.end()) {
      return makeError(Errc::not_found, "no connection " + std::to_string(*id));
    }
    Connection* c = it->second;
    if (c == &by) return makeError(Errc::invalid_argument, "kick: that is this connection");
    const std::string who = c->describe();
    log::warn(kLogSource, "FLOW-KICKED", who + " disconnected by " + by.describe());
    c->close("disconnected by an administrator");
    return Variant(Variant::Map{{"kicked", who}});
  }
  if (command == "chan_rm") {
    auto name = adminString(args, "name");
    if (!name) return name.error();
    const Channel* ch = hub_.channels.findByName(*name);
    if (ch == nullptr) return makeError(Errc::not_found, "no channel \"" + *name + "\"");
    if (auto r = hub_.channels.remove(by, ch->id); !r) return r.error();
    return Variant(Variant::Map{{"removed", *name}});
  }
  if (command == "db_rm") {
    auto name = adminString(args, "name");
    if (!name) return name.error();
    if (auto r = hub_.databases.remove(by, *name); !r) return r.error();
    return Variant(Variant::Map{{"removed", *name}});
  }
  std::string known =
      "flows, kick, chan_rm, db_rm, users, user_add, user_del, user_passwd, user_role, user_rule";
  for (const auto& [name, run] : more) known += ", " + name;
  return makeError(Errc::invalid_argument,
                   "ADMIN: unknown command \"" + command + "\" (" + known + ")");
}

}  // namespace skr::flow
