// SPDX-License-Identifier: Apache-2.0
// Database access (see database_access.h).
#include "families/databases/database_access.h"

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {
namespace {

Error noDatabase(const std::string& name) {
  return makeError(Errc::not_found, "no database \"" + name + "\"");
}

Error readOnly(const std::string& name) {
  return makeError(Errc::permission_denied,
                   "database \"" + name + "\" is a linked hub's: it is read here, written there");
}

}  // namespace

void DatabaseAccess::attach(Endpoint& e) {
  const std::string flow_db = "_flow." + std::to_string(e.id);
  if (auto db = store_.getOrCreate(flow_db, DatabaseKind::transient)) {
    (void)(*db)->set("user", Variant(e.user));
    (void)(*db)->set("client", Variant(e.client_name));
    (void)(*db)->set("connected_since", Variant(utcNowText()));
  }
  owners_[flow_db] = Owner{Owner::Kind::flow, e.user, e.id};
  if (store_.find(e.user) == nullptr) (void)store_.create(e.user, DatabaseKind::persistent);
  owners_[e.user] = Owner{Owner::Kind::user, e.user, 0};
  e.current_db = e.user;
}

void DatabaseAccess::detach(const Endpoint& e) {
  const std::string flow_db = "_flow." + std::to_string(e.id);
  owners_.erase(flow_db);
  (void)store_.remove(flow_db);
}

Result<void> DatabaseAccess::createChannelDb(const std::string& name, const std::string& owner_user,
                                             uint32_t owner_id, const Variant& props) {
  auto db = store_.getOrCreate(name, DatabaseKind::transient);
  if (!db) return db.error();
  (*db)->clear();
  if (const auto* map = props.asMap()) {
    for (const auto& [k, v] : *map) {
      if (auto r = (*db)->set(k, v); !r) return r.error();
    }
  }
  owners_[name] = Owner{Owner::Kind::channel, owner_user, owner_id};
  return {};
}

void DatabaseAccess::setChannelDbOwner(const std::string& name, uint32_t owner_id) {
  if (auto it = owners_.find(name); it != owners_.end()) it->second.endpoint = owner_id;
}

Result<PairDatabase*> DatabaseAccess::createOwnedDb(const std::string& name,
                                                    const Endpoint& owner) {
  auto db = store_.getOrCreate(name, DatabaseKind::transient);
  if (!db) return db.error();
  (*db)->clear();
  owners_[name] = Owner{Owner::Kind::flow, owner.user, owner.id};
  return *db;
}

void DatabaseAccess::removeOwnedDb(const std::string& name) {
  owners_.erase(name);
  (void)store_.remove(name);
}

Result<void> DatabaseAccess::replaceChannelProps(const std::string& name, Variant::Map props,
                                                 std::initializer_list<std::string_view> keep) {
  const Variant now = channelProps(name);
  if (const auto* old = now.asMap()) {
    for (const auto& [key, value] : *old) {
      const bool kept = std::find(keep.begin(), keep.end(), key) != keep.end();
      if (!kept && !props.contains(key)) props[key] = Variant();
    }
  }
  return setChannelProps(name, props);
}

Result<void> DatabaseAccess::setChannelProps(const std::string& name, const Variant::Map& props) {
  PairDatabase* db = store_.find(name);
  if (db == nullptr) return noDatabase(name);
  const uint64_t before = db->version();
  Result<void> r;
  for (const auto& [k, v] : props) {
    if (v.isNull()) {
      db->remove(k);
    } else if (auto s = db->set(k, v); !s) {
      r = makeError(Errc::invalid_argument, s.error().message);
      break;
    }
  }
  propsChanged(*db, before);  // the keys set before a refused one stay set
  return r;
}

void DatabaseAccess::propsChanged(const PairDatabase& db, uint64_t before) const {
  if (db.version() == before || !on_props_changed) return;
  auto it = owners_.find(db.name());
  if (it != owners_.end() && it->second.kind == Owner::Kind::channel) on_props_changed(db.name());
}

Variant DatabaseAccess::channelProps(const std::string& name) const {
  const PairDatabase* db = store_.find(name);
  return db != nullptr ? db->all() : Variant(Variant::Map{});
}

PairDatabase* DatabaseAccess::current(Endpoint& e) {
  PairDatabase* db = store_.find(e.current_db);
  if (db == nullptr) {
    // Its current database was removed: fall back to the flow's own.
    e.current_db = "_flow." + std::to_string(e.id);
    db = store_.find(e.current_db);
  }
  return db;
}

bool DatabaseAccess::canWrite(const Endpoint& e, const std::string& db) const {
  if (e.access->admin()) return true;
  if (!e.access->allows(Action::db_write, db)) return false;
  auto it = owners_.find(db);
  if (it == owners_.end()) return true;  // a named database
  switch (it->second.kind) {
    case Owner::Kind::user:
      return it->second.user_name == e.user;
    case Owner::Kind::flow:
    case Owner::Kind::channel:
      return it->second.endpoint == e.id;
  }
  return false;
}

bool DatabaseAccess::canRead(const Endpoint& e, const std::string& db) const {
  return e.access->allows(Action::db_read, db);
}

Result<void> DatabaseAccess::select(Endpoint& e, const std::string& name) {
  if (remote(name)) {
    const std::string hub = name.substr(0, name.find('/'));
    if (!validHubName(hub) || !hub_reachable || !hub_reachable(hub)) {
      return makeError(Errc::not_found,
                       "no database \"" + name + "\": no linked hub \"" + hub + "\" is up");
    }
  } else if (store_.find(name) == nullptr) {
    return noDatabase(name);
  }
  if (!canRead(e, name)) return accessDenied(e.user, Action::db_read, name);
  e.current_db = name;
  return {};
}

Result<Variant> DatabaseAccess::read(const Endpoint& e, const std::string& name,
                                     msg::DbReadWhat what, const std::string& key) const {
  const PairDatabase* db = store_.find(name);
  if (db == nullptr) return noDatabase(name);
  if (!canRead(e, name)) return accessDenied(e.user, Action::db_read, name);
  return readFrom(*db, what, key, name);
}

Result<Variant> DatabaseAccess::readFrom(const PairDatabase& db, msg::DbReadWhat what,
                                         const std::string& key, const std::string& name) {
  switch (what) {
    case msg::DbReadWhat::get:
      if (const Variant* v = db.get(key)) return *v;
      return makeError(Errc::not_found, "no variable \"" + key + "\" in database \"" + name + "\"");
    case msg::DbReadWhat::all:
      return db.all();
    case msg::DbReadWhat::keys: {
      Variant::List keys;
      for (auto& k : db.keys()) keys.emplace_back(k);
      return Variant(std::move(keys));
    }
  }
  return makeError(Errc::invalid_argument, "DB_READ: what is 0 (get), 1 (all) or 2 (keys)");
}

Result<void> DatabaseAccess::create(const Endpoint& e, const std::string& name) {
  if (name.starts_with("_")) {
    return makeError(Errc::invalid_argument, "database names starting with '_' are the hub's");
  }
  if (!e.access->allows(Action::db_write, name)) {
    return accessDenied(e.user, Action::db_write, name);
  }
  const auto created = static_cast<uint32_t>(std::count_if(
      creators_.begin(), creators_.end(), [&e](const auto& kv) { return kv.second == e.user; }));
  if (created >= e.limits.databases) return limitReached(e.user, "databases", e.limits.databases);
  auto r = store_.create(name, DatabaseKind::persistent);
  if (!r) return r.error();
  creators_[name] = e.user;
  return {};
}

Result<void> DatabaseAccess::save(const Endpoint& e, const std::string& name,
                                  std::function<void(Result<void>)> done) {
  const std::string& target = name.empty() ? e.current_db : name;
  if (remote(target)) return readOnly(target);
  const auto kind = store_.kind(target);
  if (!kind) return noDatabase(target);
  if (*kind != DatabaseKind::persistent) {
    return makeError(
        Errc::invalid_argument,
        "\"" + target + "\" is transient (a flow or channel database) and is never saved");
  }
  if (store_.dbDir().empty()) return makeError(Errc::unsupported, "the hub has no data directory");
  return store_.save(target, std::move(done));
}

Result<void> DatabaseAccess::remove(const Endpoint& e, const std::string& name) {
  if (store_.find(name) == nullptr) return noDatabase(name);
  if (!e.access->allows(Action::db_write, name)) {
    return accessDenied(e.user, Action::db_write, name);
  }
  if (owners_.count(name) != 0) {
    return makeError(Errc::permission_denied,
                     "\"" + name + "\" belongs to a user, flow or channel and cannot be removed");
  }
  auto removed = store_.remove(name);
  if (removed) creators_.erase(name);
  return removed;
}

Result<PairDatabase*> DatabaseAccess::writable(Endpoint& e, const std::string& db_name) {
  const std::string& target = db_name.empty() ? e.current_db : db_name;
  if (remote(target)) return readOnly(target);
  PairDatabase* db = db_name.empty() ? current(e) : store_.find(db_name);
  if (db == nullptr) return noDatabase(db_name);
  if (!canWrite(e, db->name())) {
    return makeError(Errc::permission_denied,
                     "database \"" + db->name() + "\" is not yours to write");
  }
  return db;
}

Result<void> DatabaseAccess::setVar(Endpoint& e, const std::string& db_name, const std::string& key,
                                    const Variant& value) {
  auto found = writable(e, db_name);
  if (!found) return found.error();
  PairDatabase* db = *found;
  const uint64_t before = db->version();
  auto r = db->set(key, value);
  propsChanged(*db, before);
  return r;
}

Result<void> DatabaseAccess::delVar(Endpoint& e, const std::string& db_name,
                                    const std::string& key) {
  auto found = writable(e, db_name);
  if (!found) return found.error();
  PairDatabase* db = *found;
  if (!db->remove(key)) {
    return makeError(Errc::not_found, "no variable \"" + key + "\" in \"" + db->name() + "\"");
  }
  propsChanged(*db, db->version() - 1);
  return {};
}

}  // namespace skr::flow
