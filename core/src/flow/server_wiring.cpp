// What crosses the server's parts: endpoints arriving and leaving, and channels created,
// removed or changed, with their databases, their pending requests and the events everyone gets.
#include "connection.h"
#include "hub_link.h"
#include "server_impl.h"

#include <skrobot/core/log.h>

#include <algorithm>

namespace skr::flow {

void FlowServer::Impl::loggedIn(Endpoint& e) {
  e.limits = e.access->limits().orElse(opt.user_limits);
  databases.attach(e);
}

void FlowServer::Impl::writeFlowStats() {
  endpoints.forEach([&](const Endpoint& e) {
    PairDatabase* db = databases.store().find("_flow." + std::to_string(e.id));
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

void FlowServer::Impl::noteFollowed(const Endpoint& e) {
  if (PairDatabase* db = databases.store().find("_flow." + std::to_string(e.id))) {
    (void)db->set("sync_following", Variant(syncs.followedBy(e.id)));
  }
}

void FlowServer::Impl::removeEndpoint(Endpoint& e) {
  if (!endpoints.remove(e.id)) return;
  HubLink* shared = e.linked_hub.empty() ? nullptr : sharedLink(e);
  connections.erase(e.id);
  if (stats.connections_open > 0 && dynamic_cast<Connection*>(&e) != nullptr) {
    --stats.connections_open;
  }
  physical.dropEndpoint(e);  // before the lists below: its grants are revoked, its offers go
  for (uint16_t id : std::vector<uint16_t>(e.subscribed)) {
    // The last relayed subscriber leaving: an owner serving paths may stop publishing to us.
    if (channels.unsubscribe(e, id)) physical.subscribersChanged(id);
  }
  for (uint16_t id : std::vector<uint16_t>(e.owned)) {
    Channel* ch = channels.find(id);
    if (ch != nullptr && ch->kind == ChannelKind::blob) {
      detachBlob(e, *ch);  // a store outlives its owner's connection
    } else {
      (void)removeChannel(e, id);
    }
  }
  if (blobs) blobs->forget(e.id);
  requests.dropRequester(e.id);
  syncs.dropEndpoint(e.id);
  channels.unpollAll(e.id);
  databases.detach(e);
  channels.unwantAll(e.id);
  dropReplicasOf(e.id);
  if (shared != nullptr) shared->released();
}

Result<Channel*> FlowServer::Impl::createChannel(Endpoint& owner, const std::string& short_name,
                                                 ChannelKind kind, const std::string& mime,
                                                 const Variant& props, uint32_t tag,
                                                 std::function<void(Result<void>)> stored) {
  return createChannelAs(owner, owner.user, short_name, kind, mime, props, tag, std::move(stored));
}

Result<Channel*> FlowServer::Impl::createChannelAs(Endpoint& owner, const std::string& user,
                                                   const std::string& short_name, ChannelKind kind,
                                                   const std::string& mime, const Variant& props,
                                                   uint32_t tag,
                                                   std::function<void(Result<void>)> stored) {
  if (!props.isNull() && !props.isMap()) {
    return makeError(Errc::invalid_argument, "channel properties must be a map");
  }
  const std::string name = user + "." + short_name;
  if (!owner.access->allows(Action::publish, name)) {
    return accessDenied(owner.user, Action::publish, name);
  }
  const bool blob = kind == ChannelKind::blob;
  if (blob && !blobs) {
    return makeError(Errc::unsupported, "this hub keeps no files: it has no data_dir");
  }
  if (blob) {
    if (Channel* again = reattachBlob(owner, name, tag)) {
      // Answered after what the store was asked before, never from inside this call.
      if (stored) blobs->barrier([stored = std::move(stored)] { stored({}); });
      return again;
    }
  }
  // Blob channels whose owner is not connected count too: they are the user's all the same.
  uint32_t held = endpoints.holdingsOf(user).channels;
  channels.forEach([&](const Channel& ch) {
    if (ch.owner == nullptr && ch.owner_user == user) ++held;
  });
  if (held >= owner.limits.channels) {
    return limitReached(user, "channels", owner.limits.channels);
  }
  // A blob channel created from a synchronous connection is owned by nobody connected.
  Endpoint* holder = blob && !owner.receivesEvents() ? nullptr : &owner;
  auto added = channels.add(holder, user, short_name, kind, mime);
  if (!added) return added;
  Channel* raw = *added;
  const uint16_t id = raw->id;
  if (auto db = databases.createChannelDb(raw->name, user, holder ? owner.id : 0, props); !db) {
    (void)channels.erase(*raw);
    return db.error();
  }
  if (blob) {
    // On disk, on the store's thread; a store that cannot be made takes the channel with it.
    blobs->create(raw->name, user,
                  [this, id, hash = raw->hash, owner_id = owner.id, tag,
                   stored = std::move(stored)](Result<void> r) {
                    Channel* ch = channels.find(id);
                    if (!r && ch != nullptr && ch->hash == hash) {
                      log::error(kLogSource, "BLOB-IO",
                                 "blob channel " + ch->name + ": " + r.error().message);
                      dropChannel(*ch);
                      if (Endpoint* e = endpoints.find(owner_id); e && e->receivesEvents()) {
                        e->onError(Code::chan_add, tag, id, toErrorCode(r.error().code),
                                   r.error().message);
                      }
                    }
                    if (stored) stored(r);
                  });
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
  dropChannel(**found);
  return {};
}

void FlowServer::Impl::dropChannel(Channel& ch) {
  const uint16_t id = ch.id;
  requests.failChannel(id, ErrorCode::owner_gone, "channel " + ch.name + " was removed");
  syncs.dropSource(id);
  physical.dropChannel(id);
  std::unique_ptr<Channel> gone = channels.erase(ch);
  databases.removeOwnedDb(gone->name);
  if (gone->kind == ChannelKind::blob && blobs) {
    blobs->drop(gone->name, [name = gone->name](Result<void> r) {
      if (!r)
        log::error(kLogSource, "BLOB-IO",
                   "removing the files of " + name + ": " + r.error().message);
    });
  }
  log::info(kLogSource, "FLOW-CHANNEL-REMOVED", gone->name + " id " + std::to_string(id));
  endpoints.forEachEventReceiver([&](Endpoint& e) { e.onChannelRemoved(*gone); });
}

Result<void> FlowServer::Impl::setProps(Endpoint& e, uint16_t id, const Variant& props) {
  auto found = channels.owned(e, id, "changes the properties of");
  if (!found) return found.error();
  Channel& ch = **found;
  const auto* map = props.asMap();
  if (map == nullptr) return makeError(Errc::invalid_argument, "channel properties must be a map");
  return databases.setChannelProps(ch.name, *map);  // EV_CHAN_HEADER from on_props_changed
}

msg::ChannelInfo FlowServer::Impl::info(const Channel& ch) const {
  msg::ChannelInfo i;
  i.id = ch.id;
  i.hash = ch.hash;
  i.kind = static_cast<uint8_t>(ch.kind);
  i.name = ch.name;
  i.owner = ch.owner_user;
  i.owner_connection = ch.owner != nullptr ? ch.owner->id : 0;
  i.mime = ch.mime;
  i.subscribers = static_cast<uint32_t>(ch.subscriber_count);
  i.props = databases.channelProps(ch.name);
  return i;
}

}  // namespace skr::flow
