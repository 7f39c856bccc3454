// SPDX-License-Identifier: Apache-2.0
// The databases room: the PairDatabases as the protocol sees them (database_access.h: who may read
// and write which; database_store.cpp and the journal: in memory and on disk), a connection's
// current database, reads of a linked hub's databases, each flow's database of statistics, and the
// DB_* / VAR_* rows of the catalogue.
#pragma once

#include "families/databases/database_access.h"
#include "families/room.h"

#include <skrobot/runtime/flow/messages.h>

#include <functional>
#include <string>

namespace skr::flow {

class Connection;

class DatabasesRoom final : public Room, public DatabaseAccess {
 public:
  explicit DatabasesRoom(Hub& hub);

  // A read of database `db` for `e` (DB_READ, or a synchronous read of a linked hub's current
  // database): here, or on a linked hub ("<hub>/<name>", through the links room; that hub applies
  // its own rules to the link's account). `done` may be called later (never after the server).
  void readDatabase(const Endpoint& e, const std::string& db, msg::DbReadWhat what,
                    const std::string& key, std::function<void(Result<Variant>)> done);

  // Its rows (catalogue.h, family databases): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(databases)

  // Room
  [[nodiscard]] Result<void> start() override;
  void stop() noexcept override;
  void loggedIn(Endpoint& e) override;
  void endpointLeft(Endpoint& e) override;
  void channelRemoved(const Channel& ch) override;
  void everySecond(Nanos now) override;

 private:
  // VAR_GET, VAR_GET_ALL or VAR_KEYS in the connection's current database, here or a linked
  // hub's (answered when the link brings it).
  void readCurrent(Connection& c, msg::DbReadWhat what, const std::string& key);
  // A database command's answer: at once, or, when `persistent` and the policy is `always`,
  // once the change is on disk (the connection's reading pauses meanwhile).
  void answerDurably(Connection& c, const Result<void>& r, bool persistent);
  // Each endpoint's traffic counters into its flow database (once a second).
  void writeFlowStats();

  bool started_ = false;  // loaded: closed (saved) at stop
};

}  // namespace skr::flow
