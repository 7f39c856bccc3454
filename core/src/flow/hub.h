// SPDX-License-Identifier: Apache-2.0
// The hub's FlowNetwork server as its parts see it: the endpoints connected now, the sessions on
// sockets, and one room per family of the protocol (families/), named as the catalogue's family
// column names them, so that the generated dispatch (dispatch.cpp) finds the room of a row by its
// family. What crosses the rooms (an endpoint logging in or leaving, a channel going, the timers)
// goes through here to every room, in the order of rooms(). FlowServer::Impl (server_impl.h) adds
// the listeners and the loop's handles. Main loop thread only.
//
// docs/internals.md has the picture of the rooms and the path of a published message.
#pragma once

#include "endpoint.h"
#include "families/admin/admin_room.h"
#include "families/blobs/blobs_room.h"
#include "families/channels/channels_room.h"
#include "families/databases/databases_room.h"
#include "families/links/links_room.h"
#include "families/physical/physical_room.h"
#include "families/services/services_room.h"
#include "families/session/session_room.h"
#include "families/sync/sync_room.h"
#include "rate_window.h"

#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/loop.h>

#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace skr::flow {

class Connection;

struct Hub {
  Hub(Loop& loop, ServerOptions options);
  virtual ~Hub() = default;
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;
  Hub(Hub&&) = delete;
  Hub& operator=(Hub&&) = delete;

  Loop& loop;
  ServerOptions opt;
  ServerStats stats;
  std::string hub_name;  // opt.hub_name, or the host's name (hub links, statistics)

  EndpointTable endpoints{opt.stats_clock};
  // The socket satellites by endpoint id, for callbacks that must find theirs again (whenAlive).
  std::unordered_map<uint32_t, Connection*> connections;
  // Connections with output to flush at the end of this loop iteration (flushDirty).
  std::vector<Connection*> dirty;

  // The rooms. Declaration order is construction order: the later ones use the earlier.
  SessionRoom session{*this};
  DatabasesRoom databases{*this};
  ChannelsRoom channels{*this};
  ServicesRoom services{*this};
  SyncRoom sync{*this};
  PhysicalRoom physical{*this};
  BlobsRoom blobs{*this};
  LinksRoom links{*this};
  AdminRoom admin{*this};
  // The order in which the rooms hear what crosses them: a leaving endpoint's paths are revoked
  // before its subscriptions end, its channels go before its requests, its databases last.
  [[nodiscard]] std::array<Room*, 9> rooms() noexcept {
    return {&session, &physical, &channels, &blobs, &services, &sync, &databases, &links, &admin};
  }

  // The order in which the rooms start (and, reversed, stop): the databases first, which the blob
  // channels brought back from their store need, then the accounts.
  [[nodiscard]] std::array<Room*, 9> lifecycle() noexcept {
    return {&databases, &blobs, &session, &channels, &services, &sync, &physical, &links, &admin};
  }

  // When the last one-second samples of the rate windows were taken (hub_stats.cpp): the spans
  // of the hub's windows; and the wall clock at the newest.
  RateWindow<0> rate_ticks{opt.stats_clock(), {}};
  int64_t rates_until_ms = 0;

  // An endpoint logged in: its limits, then every room.
  void loggedIn(Endpoint& e);
  // An endpoint leaves: every room lets go of what it holds. Idempotent.
  void removeEndpoint(Endpoint& e);
  // The connection with endpoint id `id`, if it is still there.
  [[nodiscard]] Connection* connection(uint32_t id) const noexcept;
  // Output: `c` has frames to write; they leave in flushDirty, once per loop iteration.
  void markDirty(Connection* c);
  void flushDirty();
  // The server's timers: every 20 ms, and once a second.
  void sweep(Nanos now);
  Nanos next_second = 0;
};

}  // namespace skr::flow
