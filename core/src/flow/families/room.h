// SPDX-License-Identifier: Apache-2.0
// A room: one family of the protocol in the hub (docs/internals.md, "The rooms"). A room holds its
// family's state (for most, the part it extends: the channel table, the request table, ...), the
// handlers of its catalogue rows, and what it does when something crosses the rooms.
//
// Handlers are overloads `void handle(Connection& c, msg::X& m)`, one per row of the family in
// catalogue.h; the dispatch that dispatch.cpp generates from the catalogue decodes a frame and
// calls the room's overload for its message (a row without one does not compile). The hooks below
// are the room's ops table: Hub calls them, for every room in the order of Hub::rooms(), when an
// endpoint logs in or leaves, when a channel goes, and on the server's timers.
//
// Main loop thread only, like everything in the hub's server.
#pragma once

#include <skrobot/core/clock.h>
#include <skrobot/core/result.h>

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
