// SPDX-License-Identifier: Apache-2.0
// The links room: links dialled and accepted, routes, replicas; the HUB_LINK_HELLO, LINK_OFFER,
// REPLICATE_* and TIME_PROBE rows. The links themselves are hub_link.cpp and
// hub_link_shared.cpp, the replicas replica.cpp.
#include "families/links/links_room.h"

#include "connection.h"
#include "families/links/hub_route.h"
#include "hub.h"

#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {

namespace {
constexpr const char* kLinkLog = "link";
}  // namespace

void LinksRoom::connect() {
  for (const HubLinkOptions& o : hub_.opt.links) {
    links_.push_back(std::make_unique<HubLink>(hub_, o));
    links_.back()->start();
  }
  for (const ReplicaOptions& r : hub_.opt.replicas) {
    if (auto made = replicate("hub", r.source, r.short_name, nullptr); !made) {
      log::error(kLinkLog, "FLOW-REPLICA",
                 "replica hub." + r.short_name + " of " + r.source + ": " + made.error().message);
    }
  }
}

bool LinksRoom::takeRoute(const std::string& name, size_t hops) {
  Channel* ch = hub_.channels.findByName(name);
  if (ch == nullptr) return true;
  const size_t held = routeLength(hub_.databases.channelProps(name));
  if (held <= hops || ch->owner == nullptr) return false;  // as short, or not a linked one
  log::info(kLinkLog, "HUB-ROUTE-SWITCH",
            name + ": a route of " + std::to_string(hops) + " links replaces one of " +
                std::to_string(held));
  // Its owner, a link or a shared connection, lets go of it as of any channel removed.
  (void)hub_.channels.remove(*ch->owner, ch->id);
  return true;
}

HubLink* LinksRoom::toward(std::string_view hub) const {
  for (const auto& link : links_) {
    if (link->up() && link->options().name == hub) return link.get();
  }
  for (const auto& link : links_) {
    if (link->reaches(hub)) return link.get();
  }
  return nullptr;
}

void LinksRoom::readDatabase(const std::string& db, msg::DbReadWhat what, const std::string& key,
                             std::function<void(Result<Variant>)> done) {
  const size_t slash = db.find('/');
  const std::string hub = db.substr(0, slash);
  HubLink* link = toward(hub);
  if (link == nullptr) {
    return done(makeError(Errc::not_found,
                          "no database \"" + db + "\": no linked hub \"" + hub + "\" is up"));
  }
  // The far hub's own databases lose the prefix; a hub beyond it keeps it.
  link->readDatabase(hub == link->options().name ? db.substr(slash + 1) : db, what, key,
                     std::move(done));
}

Result<void> LinksRoom::accept(Connection& c, const std::string& name) {
  if (!validHubName(name)) {
    return makeError(Errc::invalid_argument,
                     "hub name \"" + name + "\": 1 to 64 of A-Z a-z 0-9 _ -");
  }
  if (name == hub_.hub_name) {
    return makeError(Errc::invalid_argument, "\"" + name + "\" is this hub's own name");
  }
  Endpoint& self = c;
  bool taken = false;
  hub_.endpoints.forEach([&](const Endpoint& e) {
    if (&e != &self && e.linked_hub == name) taken = true;
  });
  if (taken) {
    log::warn(kLinkLog, "HUB-LINK-REFUSED",
              self.describe() + ": a hub named \"" + name + "\" is linked already");
    return makeError(Errc::already_exists, "a hub named \"" + name + "\" is linked already");
  }
  // A hub this one lists too: one connection for both (hub_link_shared.cpp).
  for (const auto& link : links_) {
    if (link->options().name != name) continue;
    if (auto shared = link->adopt(self); !shared) return shared;
  }
  self.linked_hub = name;
  log::info(kLinkLog, "HUB-LINK-IN", self.describe() + " is hub " + name);
  return {};
}

HubLink* LinksRoom::link(const Endpoint& e) const {
  for (const auto& link : links_) {
    if (link.get() == &e) return link.get();
  }
  return nullptr;
}

HubLink* LinksRoom::shared(const Endpoint& c) const {
  if (c.id == 0) return nullptr;
  for (const auto& link : links_) {
    if (link->sharedConnection() == c.id) return link.get();
  }
  return nullptr;
}

Result<Channel*> LinksRoom::offered(Connection& c, const msg::LinkOffer& m) {
  HubLink* link = shared(c);
  if (link == nullptr) {
    return makeError(Errc::invalid_argument,
                     "LINK_OFFER: this connection is not a link both hubs list");
  }
  const auto kind = static_cast<ChannelKind>(m.kind);
  if (kind != ChannelKind::streaming && kind != ChannelKind::service) {
    return makeError(Errc::invalid_argument, "only streaming and service channels cross a link");
  }
  const std::string name = linkedName(m.name, c.linked_hub, hub_.hub_name);
  if (name.empty()) {
    return makeError(Errc::invalid_argument, "\"" + m.name + "\" is not offered here");
  }
  const std::vector<std::string> route = hubRoute(m.props, c.linked_hub);
  if (!routeAccepted(route, hub_.hub_name, hub_.opt.link_hops)) {
    return makeError(Errc::invalid_argument,
                     name + ": its route comes back here or is longer than link_hops");
  }
  if (!takeRoute(name, route.size())) {
    return makeError(Errc::already_exists, name + " is here already, by a route as short");
  }
  if (c.owned.size() >= link->options().max_channels) {
    return makeError(Errc::limit_exceeded, "hub " + c.linked_hub +
                                               ": more than links[].max_channels = " +
                                               std::to_string(link->options().max_channels));
  }
  const size_t dot = name.find('.');
  return hub_.channels.createAs(c, name.substr(0, dot), name.substr(dot + 1), kind, m.mime,
                                routedProps(m.props, route), m.tag);
}

Result<void> LinksRoom::replicate(const std::string& owner_user, const std::string& source,
                                  const std::string& short_name, const Endpoint* by) {
  const std::string name = owner_user + "." + short_name;
  if (!validShortName(short_name)) {
    return makeError(Errc::invalid_argument,
                     "channel name \"" + short_name +
                         "\": 1 to 128 of A-Z a-z 0-9 _ - . (not starting with '.')");
  }
  if (by != nullptr) {
    if (!by->access->allows(Action::subscribe, source)) {
      return accessDenied(by->user, Action::subscribe, source);
    }
    if (!by->access->allows(Action::publish, name)) {
      return accessDenied(by->user, Action::publish, name);
    }
  }
  if (source == name) return makeError(Errc::invalid_argument, "a channel cannot mirror itself");
  if (const Channel* ch = hub_.channels.findByName(source);
      ch && ch->kind != ChannelKind::streaming) {
    return makeError(Errc::invalid_argument, source + " is not a streaming channel");
  }
  for (const auto& r : replicas_) {
    if (r->ownerUser() == owner_user && r->shortName() == short_name) {
      return makeError(Errc::already_exists, "a replica " + name + " exists");
    }
  }
  if (hub_.channels.findByName(name) != nullptr) {
    return makeError(Errc::already_exists, "channel " + name + " exists");
  }
  replicas_.push_back(std::make_unique<Replica>(hub_, owner_user, short_name, source,
                                                by != nullptr ? by->id : 0,
                                                by != nullptr ? by->access : nullptr));
  replicas_.back()->start();
  log::info(kLogSource, "FLOW-REPLICA", replicas_.back()->describe() + " created");
  return {};
}

Result<void> LinksRoom::stopReplica(const std::string& owner_user, const std::string& short_name,
                                    uint32_t by) {
  const auto it = std::find_if(replicas_.begin(), replicas_.end(), [&](const auto& r) {
    return r->ownerUser() == owner_user && r->shortName() == short_name && r->requester() == by;
  });
  if (it == replicas_.end()) {
    return makeError(Errc::not_found, "no replica " + owner_user + "." + short_name + " of yours");
  }
  std::unique_ptr<Replica> gone = std::move(*it);
  replicas_.erase(it);
  return {};
}

void LinksRoom::endpointLeft(Endpoint& e) {
  HubLink* shared_link = e.linked_hub.empty() ? nullptr : shared(e);
  const uint32_t requester = e.id;
  std::vector<std::unique_ptr<Replica>> gone;
  for (auto it = replicas_.begin(); it != replicas_.end();) {
    if ((*it)->requester() == requester) {
      gone.push_back(std::move(*it));
      it = replicas_.erase(it);
    } else {
      ++it;
    }
  }
  if (shared_link != nullptr) shared_link->released();
}

void LinksRoom::flowOpened(Connection& c) {
  if (shared(c) != nullptr) askOffers(c);
}

void LinksRoom::askOffers(Connection& c) {
  if (c.receivesEvents()) c.send(msg::EvLinkWanted{hub_.hub_name});
}

void LinksRoom::stop() noexcept {
  replicas_.clear();  // their channels go while everyone is still here to be told
  links_.clear();
}

void LinksRoom::everySecond(Nanos now) {
  for (const auto& link : links_) link->everySecond(now);
}

void LinksRoom::handle(Connection& c, msg::HubLinkHello& m) {
  if (auto r = accept(c, m.hub_name); !r) return c.reply(r);
  c.send(msg::HubLinkHelloOk{hub_.hub_name});
}

void LinksRoom::handle(Connection& c, msg::LinkOffer& m) {
  auto made = offered(c, m);
  if (!made) c.refused(Code::link_offer, m.tag, 0, made.error());
}

void LinksRoom::handle(Connection& c, msg::ReplicateChannel& m) {
  c.refused(Code::replicate_channel, m.tag, 0, replicate(c.user, m.source, m.short_name, &c));
}

void LinksRoom::handle(Connection& c, msg::ReplicateStop& m) {
  c.refused(Code::replicate_stop, m.tag, 0, stopReplica(c.user, m.short_name, c.id));
}

void LinksRoom::handle(Connection& c, msg::TimeProbe& m) {
  const auto now = static_cast<uint64_t>(realtimeNs());
  c.send(msg::EvTimeProbe{m.tag, m.t1, now, static_cast<uint64_t>(realtimeNs())});
}

}  // namespace skr::flow
