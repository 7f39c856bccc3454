// SPDX-License-Identifier: Apache-2.0
// The DB_* and VAR_* rows, on synchronous connections and on flows; the databases loaded at start
// and closed at stop; each flow's database.
#include "families/databases/databases_room.h"

#include "connection.h"
#include "hub.h"

#include <skrobot/runtime/log.h>

namespace skr::flow {

DatabasesRoom::DatabasesRoom(Hub& hub) : Room(hub), DatabaseAccess(hub.opt.data_dir) {
  on_props_changed = [&hub](const std::string& name) {
    if (const Channel* ch = hub.channels.findByName(name)) {
      hub.endpoints.forEachEventReceiver([&](Endpoint& e) { e.onChannelHeader(*ch); });
    }
  };
  hub_reachable = [&hub](std::string_view far) { return hub.links.toward(far) != nullptr; };
}

Result<void> DatabasesRoom::start() {
  DatabaseStore& dbs = store();
  auto loaded = dbs.loadAll();
  if (!loaded) return loaded.error();
  // The store logs each corrupt file itself (DB-CORRUPT) and sets it aside.
  if (!hub_.opt.data_dir.empty()) {
    log::info(kLogSource, "FLOW-DB-LOADED",
              std::to_string(loaded->loaded.size()) + " databases from " + dbs.dbDir().string() +
                  (loaded->problems.empty()
                       ? std::string()
                       : ", " + std::to_string(loaded->problems.size()) + " corrupt set aside") +
                  ", durability " + durabilityName(hub_.opt.durability));
  }
  dbs.startJournal(hub_.opt.durability, hub_.opt.compact_bytes,
                   [&l = hub_.loop](std::function<void()> fn) { l.post(std::move(fn)); });
  started_ = true;
  return {};
}

void DatabasesRoom::stop() noexcept {
  if (!started_) return;
  started_ = false;
  if (auto r = store().close(); !r) log::error(kLogSource, "FLOW-DB-SAVE", r.error().message);
}

void DatabasesRoom::loggedIn(Endpoint& e) {
  attach(e);
}

void DatabasesRoom::endpointLeft(Endpoint& e) {
  detach(e);
}

void DatabasesRoom::channelRemoved(const Channel& ch) {
  removeOwnedDb(ch.name);
}

void DatabasesRoom::everySecond(Nanos) {
  writeFlowStats();
}

void DatabasesRoom::writeFlowStats() {
  hub_.endpoints.forEach([&](const Endpoint& e) {
    PairDatabase* db = store().find("_flow." + std::to_string(e.id));
    if (db == nullptr) return;
    const auto put = [db](const char* key, uint64_t v) {
      (void)db->set(key, Variant(static_cast<int64_t>(v)));
    };
    put("messages_in", e.traffic.messages_in);
    put("bytes_in", e.traffic.bytes_in);
    put("messages_out", e.traffic.messages_out);
    put("bytes_out", e.traffic.bytes_out);
    put("dropped_frames", e.traffic.dropped);
    put("sync_pulses", e.traffic.sync_pulses);
    put("sync_dropped", e.traffic.sync_dropped);
  });
}

void DatabasesRoom::readDatabase(const Endpoint& e, const std::string& db, msg::DbReadWhat what,
                                 const std::string& key,
                                 std::function<void(Result<Variant>)> done) {
  if (!remote(db)) return done(read(e, db, what, key));
  if (!canRead(e, db)) return done(accessDenied(e.user, Action::db_read, db));
  hub_.links.readDatabase(db, what, key, std::move(done));
}

void DatabasesRoom::answerDurably(Connection& c, const Result<void>& r, bool persistent) {
  if (!r || !persistent || !store().writesWaitForDisk()) return c.reply(r);
  c.block();
  store().barrier(c.whenDone([](Connection& c, const Result<void>& done) { c.answerDone(done); }));
}

void DatabasesRoom::readCurrent(Connection& c, msg::DbReadWhat what, const std::string& key) {
  if (!remote(c.current_db)) {
    // Selected (and checked) by DB_SELECT; the flow's own database if it was removed since.
    return c.replyValue(readFrom(*current(c), what, key, c.current_db));
  }
  c.block();  // answered when the link brings the value
  readDatabase(c, c.current_db, what, key, c.whenRead([](Connection& c, Result<Variant> r) {
    c.replyValue(std::move(r));
    c.unblock();
  }));
}

// --- synchronous requests ----------------------------------------------------------------------

void DatabasesRoom::handle(Connection& c, msg::DbSelect& m) {
  c.reply(select(c, m.name));
}

void DatabasesRoom::handle(Connection& c, msg::DbCreate& m) {
  answerDurably(c, create(c, m.name), true);
}

void DatabasesRoom::handle(Connection& c, msg::DbSave& m) {
  // Answered once the snapshot is written (by the journal's thread).
  c.block();
  auto r =
      save(c, m.name, c.whenDone([](Connection& c, const Result<void>& r) { c.answerDone(r); }));
  if (!r) c.answerDone(r);
}

void DatabasesRoom::handle(Connection& c, msg::DbRemove& m) {
  answerDurably(c, remove(c, m.name), true);
}

void DatabasesRoom::handle(Connection& c, msg::VarGet& m) {
  readCurrent(c, msg::DbReadWhat::get, m.key);
}

void DatabasesRoom::handle(Connection& c, msg::VarSet& m) {
  answerDurably(c, setVar(c, {}, m.key, m.value), persistent(c.current_db));
}

void DatabasesRoom::handle(Connection& c, msg::VarDel& m) {
  answerDurably(c, delVar(c, {}, m.key), persistent(c.current_db));
}

void DatabasesRoom::handle(Connection& c, msg::VarGetAll&) {
  readCurrent(c, msg::DbReadWhat::all, {});
}

void DatabasesRoom::handle(Connection& c, msg::VarKeys&) {
  readCurrent(c, msg::DbReadWhat::keys, {});
}

void DatabasesRoom::handle(Connection& c, msg::DbList&) {
  Variant::List names;
  for (auto& n : store().names()) {
    if (canRead(c, n)) names.emplace_back(n);
  }
  c.send(msg::ReplyValue{Variant(std::move(names))});
}

void DatabasesRoom::handle(Connection& c, msg::DbSync&) {
  c.block();
  store().barrier(c.whenDone([](Connection& c, const Result<void>& r) { c.answerDone(r); }));
}

// --- commands on a flow -----------------------------------------------------------------------

void DatabasesRoom::handle(Connection& c, msg::DbSetCurrent& m) {
  auto r = select(c, m.name);
  c.refused(Code::db_set_current, m.tag, 0, r);
  if (r) c.onDbChanged(m.name);
}

void DatabasesRoom::handle(Connection& c, msg::DbCreateAsync& m) {
  c.refused(Code::db_create_async, m.tag, 0, create(c, m.name));
}

void DatabasesRoom::handle(Connection& c, msg::DbRemoveAsync& m) {
  c.refused(Code::db_remove_async, m.tag, 0, remove(c, m.name));
}

void DatabasesRoom::handle(Connection& c, msg::DbSaveAsync& m) {
  const uint32_t tag = m.tag;
  c.refused(Code::db_save_async, tag, 0,
            save(c, m.name, c.whenDone([tag](Connection& c, const Result<void>& r) {
              c.refused(Code::db_save_async, tag, 0, r);
            })));
}

void DatabasesRoom::handle(Connection& c, msg::VarSetAsync& m) {
  c.refused(Code::var_set_async, m.tag, 0, setVar(c, {}, m.key, m.value));
}

void DatabasesRoom::handle(Connection& c, msg::VarDelAsync& m) {
  c.refused(Code::var_del_async, m.tag, 0, delVar(c, {}, m.key));
}

void DatabasesRoom::handle(Connection& c, msg::DbSyncAsync& m) {
  store().barrier(c.whenDone([tag = m.tag](Connection& c, const Result<void>& r) {
    if (r) {
      c.send(msg::EvDbSynced{tag});
    } else {
      c.refused(Code::db_sync_async, tag, 0, r);
    }
  }));
}

void DatabasesRoom::handle(Connection& c, msg::DbRead& m) {
  if (m.what > uint8_t(msg::DbReadWhat::keys)) {
    return c.onError(
        Code::db_read, m.tag, 0, ErrorCode::invalid_argument,
        "DB_READ: what is 0 (get), 1 (all) or 2 (keys), not " + std::to_string(m.what));
  }
  readDatabase(c, m.db, static_cast<msg::DbReadWhat>(m.what), m.key,
               c.whenRead([tag = m.tag](Connection& c, Result<Variant> r) {
                 if (r) {
                   c.send(msg::EvDbValue{tag, std::move(*r)});
                 } else {
                   c.refused(Code::db_read, tag, 0, r.error());
                 }
               }));
}

}  // namespace skr::flow
