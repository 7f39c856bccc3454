// ADMIN (protocol 1.1): what an administrator does over the protocol (docs/security.md).
//   flows                        -> [{id, user, client, transport, source, channels, subscribed}]
//   kick    {"connection": N}    -> {"kicked": "<connection N (...)>"}: closes that connection
//   chan_rm {"name": "u.c"}      -> {"removed": "u.c"}: removes any channel
//   db_rm   {"name": "db"}       -> {"removed": "db"}: removes a named database
#include "connection.h"
#include "server_impl.h"

#include <skrobot/core/log.h>

namespace skr::flow {

namespace {

Result<std::string> stringArg(const Variant& args, const char* key) {
  const auto* map = args.asMap();
  const Variant* v = nullptr;
  if (map != nullptr) {
    if (auto it = map->find(key); it != map->end()) v = &it->second;
  }
  if (v == nullptr || v->asString() == nullptr) {
    return makeError(Errc::invalid_argument, std::string("needs {\"") + key + "\": <string>}");
  }
  return *v->asString();
}

Result<int64_t> intArg(const Variant& args, const char* key) {
  const auto* map = args.asMap();
  if (map != nullptr) {
    if (auto it = map->find(key); it != map->end()) {
      if (auto n = it->second.asInt64()) return *n;
    }
  }
  return makeError(Errc::invalid_argument, std::string("needs {\"") + key + "\": <integer>}");
}

}  // namespace

Result<Variant> FlowServer::Impl::admin(Connection& by, const std::string& command,
                                        const Variant& args) {
  if (!by.access->admin()) {
    return makeError(Errc::permission_denied,
                     "ADMIN " + command + ": user " + by.user + " is not an administrator");
  }
  log::info(kLogSource, "FLOW-ADMIN",
            by.describe() + ": " + command + " " + variantToJsonText(args));
  if (command == "flows") {
    Variant::List out;
    for (const auto& [id, c] : connections) {
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
    auto id = intArg(args, "connection");
    if (!id) return id.error();
    auto it = connections.find(static_cast<uint32_t>(*id));
    if (it == connections.end()) {
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
    auto name = stringArg(args, "name");
    if (!name) return name.error();
    const Channel* ch = channels.findByName(*name);
    if (ch == nullptr) return makeError(Errc::not_found, "no channel \"" + *name + "\"");
    if (auto r = removeChannel(by, ch->id); !r) return r.error();
    return Variant(Variant::Map{{"removed", *name}});
  }
  if (command == "db_rm") {
    auto name = stringArg(args, "name");
    if (!name) return name.error();
    if (auto r = databases.remove(by, *name); !r) return r.error();
    return Variant(Variant::Map{{"removed", *name}});
  }
  return makeError(Errc::invalid_argument,
                   "ADMIN: unknown command \"" + command + "\" (flows, kick, chan_rm, db_rm)");
}

}  // namespace skr::flow
