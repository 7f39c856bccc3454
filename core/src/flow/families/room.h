// SPDX-License-Identifier: Apache-2.0
// A room: one family of the protocol in the hub (docs/internals.md, "The rooms"). A room holds its
// family's state (for most, the part it extends: the channel table, the request table, ...), the
// handlers of its catalogue rows, and what it does when something crosses the rooms.
//
// Handlers are overloads `void handle(Connection& c, msg::X& m)`, one per row of the family in
// catalogue.h, declared from the catalogue by SKR_FLOW_ROOM_HANDLERS (below) and defined in the
// room's .cpp; the dispatch that dispatch.cpp generates decodes a frame and calls the room's
// overload for its message (a row without a definition does not link). The hooks below
// are the room's ops table: Hub calls them, for every room in the order of Hub::rooms(), when an
// endpoint logs in or leaves, when a channel goes, and on the server's timers.
//
// Main loop thread only, like everything in the hub's server.
#pragma once

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/catalogue.h>
#include <skrobot/runtime/result.h>

namespace skr::flow {

class Channel;
class Endpoint;
struct Hub;

class Room {
 public:
  explicit Room(Hub& hub) : hub_(hub) {}
  virtual ~Room() = default;
  Room(const Room&) = delete;
  Room& operator=(const Room&) = delete;
  Room(Room&&) = delete;
  Room& operator=(Room&&) = delete;

  // The server starts, after the databases are loaded and before anyone connects; a failure
  // stops the start (and the rooms started before are stopped).
  [[nodiscard]] virtual Result<void> start() { return {}; }
  // The server stops (in the reverse order of the rooms): what the room keeps goes, while every
  // endpoint is still there to be told.
  virtual void stop() noexcept {}
  // An endpoint logged in (its user, rules and limits are set).
  virtual void loggedIn(Endpoint& /*e*/) {}
  // An endpoint leaves: what it holds in this room goes. It is out of the endpoint table already.
  virtual void endpointLeft(Endpoint& /*e*/) {}
  // A channel goes (removed by its owner or an administrator, or with its owner): called while it
  // is still in the channel table, before everyone is told.
  virtual void channelRemoved(const Channel& /*ch*/) {}
  // Every sweep of the server (20 ms), and once a second.
  virtual void sweep(Nanos /*now*/) {}
  virtual void everySecond(Nanos /*now*/) {}

 protected:
  Hub& hub_;
};

}  // namespace skr::flow

// SKR_FLOW_ROOM_HANDLERS(family), in a room's class, declares its handlers from the catalogue:
// `void handle(Connection& c, msg::X& m);` for each row of `family` that the hub receives. A new
// row then needs only its handler's definition, in the room's .cpp (docs/internals.md, "Adding a
// code"); the generated dispatch calls it, and a row without one does not link.
#define SKR_FLOW_ROOM_HANDLERS(family) SKR_FLOW_CATALOGUE(SKR_FLOW_ROOM_ROW_##family)

// How it chooses the rows: a row is declared where its family is the room's and it goes to the
// hub (preprocessor token comparison through the SAME_a_a probes).
#define SKR_FLOW_PP_CAT(a, b) SKR_FLOW_PP_CAT_(a, b)
#define SKR_FLOW_PP_CAT_(a, b) a##b
#define SKR_FLOW_PP_SECOND(...) SKR_FLOW_PP_SECOND_(__VA_ARGS__)
#define SKR_FLOW_PP_SECOND_(a, b, ...) b
#define SKR_FLOW_PP_SAME(a, b) SKR_FLOW_PP_SECOND(SKR_FLOW_PP_SAME_##a##_##b, 0, ~)
#define SKR_FLOW_ROOM_DECLARE(room, family, dir, message)                                       \
  SKR_FLOW_PP_CAT(SKR_FLOW_ROOM_DECL_, SKR_FLOW_PP_CAT(SKR_FLOW_PP_SAME(room, family), _##dir)) \
  (message)
#define SKR_FLOW_ROOM_DECL_1_to_hub(message) void handle(Connection& c, msg::message& m);
#define SKR_FLOW_ROOM_DECL_1_to_client(message)
#define SKR_FLOW_ROOM_DECL_0_to_hub(message)
#define SKR_FLOW_ROOM_DECL_0_to_client(message)
// clang-format off
#define SKR_FLOW_PP_SAME_session_session ~, 1
#define SKR_FLOW_PP_SAME_channels_channels ~, 1
#define SKR_FLOW_PP_SAME_databases_databases ~, 1
#define SKR_FLOW_PP_SAME_services_services ~, 1
#define SKR_FLOW_PP_SAME_blobs_blobs ~, 1
#define SKR_FLOW_PP_SAME_sync_sync ~, 1
#define SKR_FLOW_PP_SAME_links_links ~, 1
#define SKR_FLOW_PP_SAME_physical_physical ~, 1
#define SKR_FLOW_PP_SAME_admin_admin ~, 1
#define SKR_FLOW_ROOM_ROW_session(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(session, family, dir, message)
#define SKR_FLOW_ROOM_ROW_channels(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(channels, family, dir, message)
#define SKR_FLOW_ROOM_ROW_databases(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(databases, family, dir, message)
#define SKR_FLOW_ROOM_ROW_services(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(services, family, dir, message)
#define SKR_FLOW_ROOM_ROW_blobs(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(blobs, family, dir, message)
#define SKR_FLOW_ROOM_ROW_sync(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(sync, family, dir, message)
#define SKR_FLOW_ROOM_ROW_links(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(links, family, dir, message)
#define SKR_FLOW_ROOM_ROW_physical(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(physical, family, dir, message)
#define SKR_FLOW_ROOM_ROW_admin(code, name, minor, dir, via, family, message, reply) SKR_FLOW_ROOM_DECLARE(admin, family, dir, message)
// clang-format on
