// SPDX-License-Identifier: Apache-2.0
// Channels made, changed and removed, with their databases and the events everyone gets; the
// CHAN_*, SUBSCRIBE, SUBSCRIBE_QUEUE, SUBSCRIBE_RATE, UNSUBSCRIBE, PUBLISH and POLL_* rows.
#include "families/channels/channels_room.h"

#include "connection.h"
#include "hub.h"

#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {

ChannelsRoom::ChannelsRoom(Hub& hub) : Room(hub), ChannelTable(hub.opt.stats_clock) {}

Result<Channel*> ChannelsRoom::create(Endpoint& owner, const std::string& short_name,
                                      ChannelKind kind, const std::string& mime,
                                      const Variant& props, uint32_t tag,
                                      std::function<void(Result<void>)> stored) {
  return createAs(owner, owner.user, short_name, kind, mime, props, tag, std::move(stored));
}

Result<Channel*> ChannelsRoom::createAs(Endpoint& owner, const std::string& user,
                                        const std::string& short_name, ChannelKind kind,
                                        const std::string& mime, const Variant& props, uint32_t tag,
                                        std::function<void(Result<void>)> stored) {
  if (!props.isNull() && !props.isMap()) {
    return makeError(Errc::invalid_argument, "channel properties must be a map");
  }
  const std::string name = user + "." + short_name;
  if (!owner.access->allows(Action::publish, name)) {
    return accessDenied(owner.user, Action::publish, name);
  }
  BlobsRoom& blobs = hub_.blobs;
  const bool blob = kind == ChannelKind::blob;
  const bool far = blob && hub_.links.link(owner) != nullptr;  // its files stay on the far hub
  if (blob && !far && blobs.store() == nullptr) {
    return makeError(Errc::unsupported, "this hub keeps no files: it has no data_dir");
  }
  if (blob && !far) {
    if (Channel* again = blobs.reattach(owner, name, tag)) {
      // Answered after what the store was asked before, never from inside this call.
      if (stored) blobs.store()->barrier([stored = std::move(stored)] { stored({}); });
      return again;
    }
  }
  // Blob channels whose owner is not connected count too: they are the user's all the same.
  uint32_t held = hub_.endpoints.holdingsOf(user).channels;
  forEach([&](const Channel& ch) {
    if (ch.owner == nullptr && ch.owner_user == user) ++held;
  });
  if (held >= owner.limits.channels) {
    return limitReached(user, "channels", owner.limits.channels);
  }
  // A blob channel created from a synchronous connection is owned by nobody connected.
  Endpoint* holder = blob && !owner.receivesEvents() ? nullptr : &owner;
  auto added = add(holder, user, short_name, kind, mime);
  if (!added) return added;
  Channel* raw = *added;
  raw->far = far;
  const uint16_t id = raw->id;
  if (auto db = hub_.databases.createChannelDb(raw->name, user, holder ? owner.id : 0, props);
      !db) {
    (void)erase(*raw);
    return db.error();
  }
  if (blob && !far) blobs.made(*raw, owner.id, tag, std::move(stored));
  log::info(kLogSource, "FLOW-CHANNEL-ADDED",
            raw->name + " id " + std::to_string(id) + " (" + std::string(channelKindName(kind)) +
                ") by " + owner.describe());
  hub_.endpoints.forEachEventReceiver(
      [&](Endpoint& e) { e.onChannelAdded(*raw, &e == &owner ? tag : 0); });
  // In-process subscriptions waiting for this name.
  for (uint32_t eid : wanting(raw->name)) {
    Endpoint* e = hub_.endpoints.find(eid);
    if (e != nullptr && find(id) == raw) (void)subscribe(*e, id);
  }
  if (find(id) != raw) return makeError(Errc::not_found, "channel removed");
  return raw;
}

Result<void> ChannelsRoom::remove(Endpoint& by, uint16_t id) {
  // An administrator removes any channel; anyone else only its own.
  auto found = by.access->admin() ? existing(id) : owned(by, id, "removes");
  if (!found) return found.error();
  drop(**found);
  return {};
}

void ChannelsRoom::drop(Channel& ch) {
  const uint16_t id = ch.id;
  for (Room* room : hub_.rooms()) room->channelRemoved(ch);
  std::unique_ptr<Channel> gone = erase(ch);
  log::info(kLogSource, "FLOW-CHANNEL-REMOVED", gone->name + " id " + std::to_string(id));
  hub_.endpoints.forEachEventReceiver([&](Endpoint& e) { e.onChannelRemoved(*gone); });
}

Result<void> ChannelsRoom::setProps(Endpoint& e, uint16_t id, const Variant& props) {
  auto found = owned(e, id, "changes the properties of");
  if (!found) return found.error();
  Channel& ch = **found;
  const auto* map = props.asMap();
  if (map == nullptr) return makeError(Errc::invalid_argument, "channel properties must be a map");
  return hub_.databases.setChannelProps(ch.name, *map);  // EV_CHAN_HEADER from on_props_changed
}

msg::ChannelInfo ChannelsRoom::info(const Channel& ch) const {
  msg::ChannelInfo i;
  i.id = ch.id;
  i.hash = ch.hash;
  i.kind = static_cast<uint8_t>(ch.kind);
  i.name = ch.name;
  i.owner = ch.owner_user;
  i.owner_connection = ch.owner != nullptr ? ch.owner->id : 0;
  i.mime = ch.mime;
  i.subscribers = static_cast<uint32_t>(ch.subscriber_count);
  i.props = hub_.databases.channelProps(ch.name);
  return i;
}

Result<void> ChannelsRoom::subscribeAndTell(Endpoint& e, uint16_t id) {
  auto r = subscribe(e, id);
  if (r) hub_.physical.subscribersChanged(id);
  return r;
}

Result<void> ChannelsRoom::unsubscribeAndTell(Endpoint& e, uint16_t id) {
  hub_.physical.unsubscribed(e, id);
  auto r = unsubscribe(e, id);
  if (r) hub_.physical.subscribersChanged(id);
  return r;
}

void ChannelsRoom::endpointLeft(Endpoint& e) {
  for (uint16_t id : std::vector<uint16_t>(e.subscribed)) {
    // The last relayed subscriber leaving: an owner serving paths may stop publishing to us.
    if (unsubscribe(e, id)) hub_.physical.subscribersChanged(id);
  }
  for (uint16_t id : std::vector<uint16_t>(e.owned)) {
    Channel* ch = find(id);
    if (ch != nullptr && ch->kind == ChannelKind::blob && !ch->far) {
      hub_.blobs.detach(e, *ch);  // a store outlives its owner's connection
    } else {
      (void)remove(e, id);
    }
  }
  unpollAll(e.id);
  unwantAll(e.id);
}

// --- synchronous requests ----------------------------------------------------------------------

void ChannelsRoom::handle(Connection& c, msg::ChanList&) {
  msg::ChannelList list;
  forEach([&](const Channel& ch) {
    if (c.sees(ch)) list.channels.push_back(info(ch));
  });
  c.send(list);
}

void ChannelsRoom::handle(Connection& c, msg::ChanInfoByName& m) {
  const Channel* ch = findByName(m.name);
  if (ch == nullptr || !c.sees(*ch)) {
    c.replyError(ErrorCode::not_found, "no channel \"" + m.name + "\"");
  } else {
    c.send(msg::ChannelInfoReply{info(*ch)});
  }
}

void ChannelsRoom::handle(Connection& c, msg::PollRegister& m) {
  c.reply(pollRegister(c.id, m.chan_id));
}

void ChannelsRoom::handle(Connection& c, msg::PollFetch& m) {
  auto kept = pollFetch(m.chan_id);
  if (!kept) return c.reply(kept.error());
  c.send(msg::PollData{kept->first, msg::Rest{kept->second}});
}

void ChannelsRoom::handle(Connection& c, msg::PollDeregister& m) {
  c.reply(pollDeregister(c.id, m.chan_id));
}

// --- commands on a flow -----------------------------------------------------------------------

void ChannelsRoom::handle(Connection& c, msg::ChanAdd& m) {
  const auto kind = static_cast<ChannelKind>(m.kind);
  if (c.protocolMinor() < minorOfKind(kind)) {
    c.onError(Code::chan_add, m.tag, 0, ErrorCode::invalid_argument,
              std::string(channelKindName(kind)) + " channels need protocol 1." +
                  std::to_string(minorOfKind(kind)));
    return;
  }
  auto r = create(c, m.short_name, kind, m.mime, m.props, m.tag);
  if (!r) c.refused(Code::chan_add, m.tag, 0, r.error());
}

void ChannelsRoom::handle(Connection& c, msg::ChanRemove& m) {
  c.refused(Code::chan_remove, m.tag, m.chan_id, remove(c, m.chan_id));
}

void ChannelsRoom::handle(Connection& c, msg::Subscribe& m) {
  c.refused(Code::subscribe, m.tag, m.chan_id, subscribeAndTell(c, m.chan_id));
}

void ChannelsRoom::handle(Connection& c, msg::SubscribeQueue& m) {
  subscribeWith(c, Code::subscribe_queue, m.tag, m.chan_id, m.queue_bytes, 0);
}

void ChannelsRoom::handle(Connection& c, msg::SubscribeRate& m) {
  subscribeWith(c, Code::subscribe_rate, m.tag, m.chan_id, m.queue_bytes, m.max_hz);
}

void ChannelsRoom::subscribeWith(Connection& c, Code code, uint32_t tag, uint16_t chan_id,
                                 uint32_t queue_bytes, uint16_t max_hz) {
  if (auto r = subscribeAndTell(c, chan_id); !r) {
    c.refused(code, tag, chan_id, r);
    return;
  }
  c.capRate(chan_id, max_hz);
  const size_t granted = c.askQueue(chan_id, queue_bytes);
  if (granted >= queue_bytes) return;
  // Subscribed all the same: the subscriber hears what it got, the operator why.
  const std::string what = "subscribed with a queue of " + std::to_string(granted) +
                           " bytes, not the " + std::to_string(queue_bytes) +
                           " asked (server.subscriber_queue_max_bytes)";
  const Channel* ch = find(chan_id);
  log::warn(
      kLogSource, "FLOW-QUEUE-CLAMPED",
      c.describe() + ": " + (ch != nullptr ? ch->name : std::to_string(chan_id)) + ": " + what);
  c.onError(code, tag, chan_id, ErrorCode::limit_exceeded, what);
}

void ChannelsRoom::handle(Connection& c, msg::Unsubscribe& m) {
  c.refused(Code::unsubscribe, m.tag, m.chan_id, unsubscribeAndTell(c, m.chan_id));
  c.releaseQueue(m.chan_id);
}

void ChannelsRoom::handle(Connection& c, msg::Publish& m) {
  // The hot path: the payload stays in the connection's read buffer.
  c.refused(Code::publish, 0, m.chan_id, publish(c, m.chan_id, m.payload.bytes));
}

void ChannelsRoom::handle(Connection& c, msg::ChanSetProps& m) {
  c.refused(Code::chan_set_props, m.tag, m.chan_id, setProps(c, m.chan_id, m.props));
}

}  // namespace skr::flow
