// What crosses the server's parts: endpoints arriving and leaving, and channels created,
// removed or changed, with their databases, their pending requests and the events everyone gets.
#include "connection.h"
#include "server_impl.h"

#include <skrobot/core/log.h>

#include <algorithm>

namespace skr::flow {

void FlowServer::Impl::loggedIn(Endpoint& e) {
  e.limits = e.access->limits().orElse(opt.user_limits);
  databases.attach(e);
}

void FlowServer::Impl::removeEndpoint(Endpoint& e) {
  if (!endpoints.remove(e.id)) return;
  connections.erase(e.id);
  if (stats.connections_open > 0 && dynamic_cast<Connection*>(&e) != nullptr) {
    --stats.connections_open;
  }
  for (uint16_t id : std::vector<uint16_t>(e.subscribed)) (void)channels.unsubscribe(e, id);
  for (uint16_t id : std::vector<uint16_t>(e.owned)) (void)removeChannel(e, id);
  requests.dropRequester(e.id);
  databases.detach(e);
  channels.unwantAll(e.id);
}

Result<Channel*> FlowServer::Impl::createChannel(Endpoint& owner, const std::string& short_name,
                                                 ChannelKind kind, const std::string& mime,
                                                 const Variant& props, uint32_t tag) {
  if (!props.isNull() && !props.isMap()) {
    return makeError(Errc::invalid_argument, "channel properties must be a map");
  }
  if (const std::string name = owner.user + "." + short_name;
      !owner.access->allows(Action::publish, name)) {
    return accessDenied(owner.user, Action::publish, name);
  }
  if (endpoints.holdingsOf(owner.user).channels >= owner.limits.channels) {
    return limitReached(owner.user, "channels", owner.limits.channels);
  }
  auto added = channels.add(owner, short_name, kind, mime);
  if (!added) return added;
  Channel* raw = *added;
  const uint16_t id = raw->id;
  if (auto db = databases.createChannelDb(raw->name, owner, props); !db) {
    (void)channels.erase(*raw);
    return db.error();
  }
  log::info(kLogSource, "FLOW-CHANNEL-ADDED",
            raw->name + " id " + std::to_string(id) + " (" + std::string(channelKindName(kind)) +
                ") by " + owner.describe());
  endpoints.forEachEventReceiver(
      [&](Endpoint& e) { e.onChannelAdded(*raw, &e == &owner ? tag : 0); });
  // In-process subscriptions waiting for this name.
  for (uint32_t eid : channels.wanting(raw->name)) {
    Endpoint* e = endpoints.find(eid);
    if (e != nullptr && channels.find(id) == raw) (void)channels.subscribe(*e, id);
  }
  if (channels.find(id) != raw) return makeError(Errc::not_found, "channel removed");
  return raw;
}

Result<void> FlowServer::Impl::removeChannel(Endpoint& by, uint16_t id) {
  // An administrator removes any channel; anyone else only its own.
  auto found = by.access->admin() ? channels.existing(id) : channels.owned(by, id, "removes");
  if (!found) return found.error();
  Channel& ch = **found;
  requests.failChannel(id, ErrorCode::owner_gone, "channel " + ch.name + " was removed");
  std::unique_ptr<Channel> gone = channels.erase(ch);
  databases.removeChannelDb(gone->name);
  log::info(kLogSource, "FLOW-CHANNEL-REMOVED", gone->name + " id " + std::to_string(id));
  endpoints.forEachEventReceiver([&](Endpoint& e) { e.onChannelRemoved(*gone); });
  return {};
}

Result<void> FlowServer::Impl::setProps(Endpoint& e, uint16_t id, const Variant& props) {
  auto found = channels.owned(e, id, "changes the properties of");
  if (!found) return found.error();
  Channel& ch = **found;
  const auto* map = props.asMap();
  if (map == nullptr) return makeError(Errc::invalid_argument, "channel properties must be a map");
  if (auto r = databases.setChannelProps(ch.name, *map); !r) return r;
  endpoints.forEachEventReceiver([&](Endpoint& r) { r.onChannelHeader(ch); });
  return {};
}

msg::ChannelInfo FlowServer::Impl::info(const Channel& ch) const {
  msg::ChannelInfo i;
  i.id = ch.id;
  i.hash = ch.hash;
  i.kind = static_cast<uint8_t>(ch.kind);
  i.name = ch.name;
  i.owner = ch.owner != nullptr ? ch.owner->user : std::string();
  i.owner_connection = ch.owner != nullptr ? ch.owner->id : 0;
  i.mime = ch.mime;
  i.subscribers = static_cast<uint32_t>(ch.subscriber_count);
  i.props = databases.channelProps(ch.name);
  return i;
}

}  // namespace skr::flow
