// SPDX-License-Identifier: Apache-2.0
// What crosses the rooms: endpoints logging in and leaving, the output of connections, the
// server's timers.
#include "hub.h"

#include "connection.h"

#include <skrobot/runtime/log.h>

#include <unistd.h>

#include <cctype>
#include <cstring>

namespace skr::flow {

namespace {

// The host's name as a hub name: up to its first '.', other characters than A-Z a-z 0-9 _ -
// made '-'.
std::string hostHubName() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0 || host[0] == '\0') return "hub";
  std::string name(host, std::strcspn(host, "."));
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '-';
  }
  if (name.size() > 64) name.resize(64);
  return name.empty() ? "hub" : name;
}

}  // namespace

Hub::Hub(Loop& l, ServerOptions options)
    : loop(l),
      opt(std::move(options)),
      hub_name(opt.hub_name.empty() ? hostHubName() : opt.hub_name) {}

void Hub::loggedIn(Endpoint& e) {
  e.limits = e.access->limits().orElse(opt.user_limits);
  for (Room* room : rooms()) room->loggedIn(e);
}

void Hub::removeEndpoint(Endpoint& e) {
  if (!endpoints.remove(e.id)) return;
  if (connections.erase(e.id) != 0 && stats.connections_open > 0) --stats.connections_open;
  for (Room* room : rooms()) room->endpointLeft(e);
}

Connection* Hub::connection(uint32_t id) const noexcept {
  auto it = connections.find(id);
  return it == connections.end() ? nullptr : it->second;
}

void Hub::markDirty(Connection* c) {
  if (c->flush_queued || c->state() == Connection::State::closing) return;
  c->flush_queued = true;
  dirty.push_back(c);
}

void Hub::flushDirty() {
  // flush() may close a connection (which takes itself out of `dirty`).
  while (!dirty.empty()) {
    std::vector<Connection*> batch;
    batch.swap(dirty);
    for (Connection* c : batch) {
      c->flush_queued = false;
      c->flush();
    }
  }
}

void Hub::sweep(Nanos now) {
  std::vector<Connection*> late;
  for (auto& [id, c] : connections) {
    if (c->state() == Connection::State::login && now > c->login_deadline) late.push_back(c);
  }
  for (Connection* c : late) {
    log::warn(kLogSource, "FLOW-LOGIN-TIMEOUT", c->describe() + ": no login in time");
    c->close("login timeout");
  }
  for (Room* room : rooms()) room->sweep(now);
  if (now >= next_second) {
    next_second = now + kNsPerSec;
    for (Room* room : rooms()) room->everySecond(now);
  }
}

}  // namespace skr::flow
