// PairDatabases as the protocol sees them: one per flow ("_flow.<id>", transient), per user
// (named after the user, persistent), per channel (named after the channel, transient: its
// properties), plus named ones anybody may create. Anyone logged in reads any database; writes
// go to named databases, one's own user and flow databases, and (through CHAN_SET_PROPS or as
// the owner) one's own channels' databases.
#include "server_impl.h"

#include <skrobot/core/log.h>

namespace skr::flow {

ErrorCode toErrorCode(Errc code) noexcept {
  switch (code) {
    case Errc::ok:
      return ErrorCode::ok;
    case Errc::invalid_argument:
    case Errc::config_error:
    case Errc::parse_error:
      return ErrorCode::invalid_argument;
    case Errc::not_found:
      return ErrorCode::not_found;
    case Errc::already_exists:
      return ErrorCode::already_exists;
    case Errc::permission_denied:
      return ErrorCode::permission_denied;
    case Errc::timeout:
      return ErrorCode::timeout;
    case Errc::limit_exceeded:
      return ErrorCode::limit_exceeded;
    case Errc::protocol_error:
      return ErrorCode::protocol_error;
    case Errc::io_error:
      return ErrorCode::io_error;
    default:
      return ErrorCode::internal;
  }
}

PairDatabase* FlowServer::Impl::currentDb(Endpoint& e) {
  PairDatabase* db = dbs.find(e.current_db);
  if (db == nullptr) {
    // Its current database was removed: fall back to the flow's own.
    e.current_db = "_flow." + std::to_string(e.id);
    db = dbs.find(e.current_db);
  }
  return db;
}

bool FlowServer::Impl::canWrite(const Endpoint& e, const std::string& db) const {
  auto it = db_owners.find(db);
  if (it == db_owners.end()) return true;  // a named database
  switch (it->second.kind) {
    case DbOwner::Kind::user:
      return it->second.user_name == e.user;
    case DbOwner::Kind::flow:
    case DbOwner::Kind::channel:
      return it->second.endpoint == e.id;
  }
  return false;
}

ErrorCode FlowServer::Impl::selectDb(Endpoint& e, const std::string& name, std::string& why) {
  if (dbs.find(name) == nullptr) {
    why = "no database \"" + name + "\"";
    return ErrorCode::not_found;
  }
  e.current_db = name;
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::createDb(Endpoint&, const std::string& name, std::string& why) {
  if (name.starts_with("_")) {
    why = "database names starting with '_' are the hub's";
    return ErrorCode::invalid_argument;
  }
  auto r = dbs.create(name, DatabaseKind::persistent);
  if (!r) {
    why = r.error().message;
    return toErrorCode(r.error().code);
  }
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::saveDb(Endpoint& e, const std::string& name, std::string& why) {
  const std::string& target = name.empty() ? e.current_db : name;
  const auto kind = dbs.kind(target);
  if (!kind) {
    why = "no database \"" + target + "\"";
    return ErrorCode::not_found;
  }
  if (*kind != DatabaseKind::persistent) {
    why = "\"" + target + "\" is transient (a flow or channel database) and is never saved";
    return ErrorCode::invalid_argument;
  }
  if (opt.data_dir.empty()) {
    why = "the hub has no data directory";
    return ErrorCode::unsupported;
  }
  if (auto r = dbs.save(target); !r) {
    why = r.error().message;
    log::error(kLogSource, "FLOW-DB-SAVE", "database " + target + ": " + why);
    return toErrorCode(r.error().code);
  }
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::removeDb(Endpoint&, const std::string& name, std::string& why) {
  if (db_owners.count(name) != 0) {
    why = "\"" + name + "\" belongs to a user, flow or channel and cannot be removed";
    return ErrorCode::permission_denied;
  }
  if (auto r = dbs.remove(name); !r) {
    why = r.error().message;
    return toErrorCode(r.error().code);
  }
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::setVar(Endpoint& e, const std::string& db_name, const std::string& key,
                                   const Variant& value, std::string& why) {
  PairDatabase* db = db_name.empty() ? currentDb(e) : dbs.find(db_name);
  if (db == nullptr) {
    why = "no database \"" + db_name + "\"";
    return ErrorCode::not_found;
  }
  if (!canWrite(e, db->name())) {
    why = "database \"" + db->name() + "\" is not yours to write";
    return ErrorCode::permission_denied;
  }
  if (auto r = db->set(key, value); !r) {
    why = r.error().message;
    return toErrorCode(r.error().code);
  }
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::delVar(Endpoint& e, const std::string& db_name, const std::string& key,
                                   std::string& why) {
  PairDatabase* db = db_name.empty() ? currentDb(e) : dbs.find(db_name);
  if (db == nullptr) {
    why = "no database \"" + db_name + "\"";
    return ErrorCode::not_found;
  }
  if (!canWrite(e, db->name())) {
    why = "database \"" + db->name() + "\" is not yours to write";
    return ErrorCode::permission_denied;
  }
  if (!db->remove(key)) {
    why = "no variable \"" + key + "\" in \"" + db->name() + "\"";
    return ErrorCode::not_found;
  }
  return ErrorCode::ok;
}

}  // namespace skr::flow
