// SPDX-License-Identifier: Apache-2.0
// The admin room: what an administrator does over the protocol (ADMIN, docs/security.md): the
// connections (flows, kick), any channel or named database removed (chan_rm, db_rm), and the
// accounts of the users file, changed on the authenticator's worker thread while the connection
// waits (users, user_add, user_del, user_passwd, user_role, user_rule).
#pragma once

#include "families/room.h"

#include <skrobot/runtime/flow/messages.h>

#include <functional>
#include <map>
#include <string>

namespace skr::flow {

class Connection;

class AdminRoom final : public Room {
 public:
  explicit AdminRoom(Hub& hub) : Room(hub) {}

  // Its rows (catalogue.h, family admin): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(admin)

  // Commands of the hub's other parts (FlowServer::addAdminCommand): the supervisor's sat_*.
  std::map<std::string,
           std::function<void(const Variant& args, std::function<void(Result<Variant>)> answer)>>
      more;

 private:
  // flows, kick, chan_rm, db_rm: answered at once.
  Result<Variant> command(Connection& by, const std::string& command, const Variant& args);
  // users and user_*: answered once the authenticator's worker changed the users file.
  void users(Connection& c, const std::string& command, const Variant& args);
};

}  // namespace skr::flow
