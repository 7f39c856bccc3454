// Channels: creation, removal, subscriptions and publishing.
#include "server_impl.h"

#include <skrobot/core/log.h>

#include <algorithm>

namespace skr::flow {
namespace {

bool validShortName(const std::string& s) {
  if (s.empty() || s.size() > 128 || s.front() == '.') return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

template <class F>
void forEachEventReceiver(FlowServer::Impl& s, F&& f) {
  // Copy the ids: a local handler may add or remove endpoints.
  std::vector<uint32_t> ids;
  ids.reserve(s.endpoints.size());
  for (const auto& [id, e] : s.endpoints) {
    if (e->receivesEvents()) ids.push_back(id);
  }
  for (uint32_t id : ids) {
    auto it = s.endpoints.find(id);
    if (it != s.endpoints.end()) f(*it->second);
  }
}

}  // namespace

Channel* FlowServer::Impl::channel(uint16_t id) noexcept {
  return id < channels.size() ? channels[id].get() : nullptr;
}

Channel* FlowServer::Impl::channelByName(const std::string& name) noexcept {
  auto it = channel_by_name.find(name);
  return it == channel_by_name.end() ? nullptr : channel(it->second);
}

Channel* FlowServer::Impl::existing(uint16_t id, ErrorCode& err, std::string& why) {
  Channel* ch = channel(id);
  if (ch == nullptr) {
    why = "no channel with id " + std::to_string(id);
    err = ErrorCode::not_found;
  }
  return ch;
}

Channel* FlowServer::Impl::owned(const Endpoint& e, uint16_t id, const char* action, ErrorCode& err,
                                 std::string& why) {
  Channel* ch = existing(id, err, why);
  if (ch != nullptr && ch->owner != &e) {
    why = std::string("only the owner ") + action + " " + ch->name;
    err = ErrorCode::permission_denied;
    return nullptr;
  }
  return ch;
}

msg::ChannelInfo FlowServer::Impl::info(const Channel& ch) {
  msg::ChannelInfo i;
  i.id = ch.id;
  i.hash = ch.hash;
  i.kind = static_cast<uint8_t>(ch.kind);
  i.name = ch.name;
  i.owner = ch.owner != nullptr ? ch.owner->user : std::string();
  i.owner_connection = ch.owner != nullptr ? ch.owner->id : 0;
  i.mime = ch.mime;
  i.subscribers = static_cast<uint32_t>(ch.subscriber_count);
  const PairDatabase* db = dbs.find(ch.name);
  i.props = db != nullptr ? db->all() : Variant(Variant::Map{});
  return i;
}

Result<Channel*> FlowServer::Impl::createChannel(Endpoint& owner, const std::string& short_name,
                                                 ChannelKind kind, const std::string& mime,
                                                 const Variant& props, uint32_t tag) {
  if (!validShortName(short_name)) {
    return makeError(Errc::invalid_argument,
                     "channel name \"" + short_name +
                         "\": 1 to 128 of A-Z a-z 0-9 _ - . (not starting with '.')");
  }
  if (kind == ChannelKind::blob) {
    return makeError(Errc::invalid_argument, "blob channels are not implemented by this hub");
  }
  if (kind != ChannelKind::streaming && kind != ChannelKind::service) {
    return makeError(Errc::invalid_argument, "unknown channel kind");
  }
  if (!props.isNull() && !props.isMap()) {
    return makeError(Errc::invalid_argument, "channel properties must be a map");
  }
  const std::string name = owner.user + "." + short_name;
  if (channel_by_name.count(name) != 0) {
    return makeError(Errc::already_exists, "channel " + name + " exists");
  }
  if (channel_count >= kMaxChannels - 1) {
    return makeError(Errc::limit_exceeded, "the hub holds its maximum of channels");
  }
  // Ids rotate so that a removed channel's id is not reused at once.
  if (channels.size() < kMaxChannels) channels.resize(kMaxChannels);
  uint16_t id = next_channel_hint;
  while (channels[id] != nullptr || id == 0) id = static_cast<uint16_t>((id + 1) % kMaxChannels);
  next_channel_hint = static_cast<uint16_t>((id + 1) % kMaxChannels);

  auto db = dbs.getOrCreate(name, DatabaseKind::transient);
  if (!db) return db.error();
  (*db)->clear();
  if (const auto* map = props.asMap()) {
    for (const auto& [k, v] : *map) {
      if (auto r = (*db)->set(k, v); !r) return r.error();
    }
  }
  db_owners[name] = DbOwner{DbOwner::Kind::channel, owner.user, owner.id};

  auto ch = std::make_unique<Channel>();
  ch->id = id;
  ch->hash = rng() | 1;  // never 0
  ch->kind = kind;
  ch->name = name;
  ch->mime = mime;
  ch->owner = &owner;
  Channel* raw = ch.get();
  channels[id] = std::move(ch);
  channel_by_name[name] = id;
  ++channel_count;
  owner.owned.push_back(id);
  log::info(kLogSource, "FLOW-CHANNEL-ADDED",
            name + " id " + std::to_string(id) + " (" + std::string(channelKindName(kind)) +
                ") by " + owner.describe());
  forEachEventReceiver(*this, [&](Endpoint& e) { e.onChannelAdded(*raw, &e == &owner ? tag : 0); });
  // In-process subscriptions waiting for this name.
  auto [lo, hi] = local_wanted.equal_range(name);
  std::vector<uint32_t> waiting;
  for (auto it = lo; it != hi; ++it) waiting.push_back(it->second);
  for (uint32_t eid : waiting) {
    auto it = endpoints.find(eid);
    std::string why;
    if (it != endpoints.end() && channel(id) == raw) (void)subscribe(*it->second, id, why);
  }
  return channel(id) == raw ? Result<Channel*>(raw)
                            : Result<Channel*>(makeError(Errc::not_found, "channel removed"));
}

ErrorCode FlowServer::Impl::removeChannel(Endpoint& by, uint16_t id, std::string& why) {
  ErrorCode err = ErrorCode::ok;
  Channel* ch = owned(by, id, "removes", err, why);
  if (ch == nullptr) return err;
  failRequests(id, ErrorCode::owner_gone, "channel " + ch->name + " was removed");
  for (Endpoint* s : ch->subscribers) {
    if (s != nullptr) std::erase(s->subscribed, id);
  }
  std::erase(by.owned, id);
  std::unique_ptr<Channel> gone = std::move(channels[id]);
  channel_by_name.erase(gone->name);
  --channel_count;
  db_owners.erase(gone->name);
  (void)dbs.remove(gone->name);
  log::info(kLogSource, "FLOW-CHANNEL-REMOVED", gone->name + " id " + std::to_string(id));
  forEachEventReceiver(*this, [&](Endpoint& e) { e.onChannelRemoved(*gone); });
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::subscribe(Endpoint& e, uint16_t id, std::string& why) {
  ErrorCode err = ErrorCode::ok;
  Channel* ch = existing(id, err, why);
  if (ch == nullptr) return err;
  if (ch->kind != ChannelKind::streaming) {
    why = ch->name + " is not a streaming channel";
    return ErrorCode::invalid_argument;
  }
  if (std::find(ch->subscribers.begin(), ch->subscribers.end(), &e) != ch->subscribers.end()) {
    return ErrorCode::ok;  // already subscribed
  }
  ch->subscribers.push_back(&e);
  e.subscribed.push_back(id);
  if (++ch->subscriber_count == 1 && ch->owner != nullptr) ch->owner->onSubscribers(*ch, true);
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::unsubscribe(Endpoint& e, uint16_t id, std::string& why) {
  ErrorCode err = ErrorCode::ok;
  Channel* ch = existing(id, err, why);
  if (ch == nullptr) return err;
  auto it = std::find(ch->subscribers.begin(), ch->subscribers.end(), &e);
  if (it == ch->subscribers.end()) return ErrorCode::ok;
  if (dispatching > 0) {
    *it = nullptr;  // tombstone: a publish is iterating this list
    tombstoned.push_back(id);
  } else {
    ch->subscribers.erase(it);
  }
  std::erase(e.subscribed, id);
  if (--ch->subscriber_count == 0 && ch->owner != nullptr && ch->owner != &e) {
    ch->owner->onSubscribers(*ch, false);
  }
  return ErrorCode::ok;
}

void FlowServer::Impl::compact(Channel& ch) {
  std::erase(ch.subscribers, nullptr);
}

ErrorCode FlowServer::Impl::publish(Endpoint& e, uint16_t id, std::string_view payload,
                                    std::string& why) {
  ErrorCode err = ErrorCode::ok;
  Channel* ch = owned(e, id, "publishes to", err, why);
  if (ch == nullptr) return err;
  if (ch->kind != ChannelKind::streaming) {
    why = ch->name + " is not a streaming channel";
    return ErrorCode::invalid_argument;
  }
  ++ch->seq;
  if (ch->polled) ch->last.assign(payload);
  ++dispatching;
  // Index loop: a local handler may subscribe (appends) or unsubscribe (tombstones).
  for (size_t i = 0; i < ch->subscribers.size(); ++i) {
    if (Endpoint* s = ch->subscribers[i]) s->onData(*ch, payload);
    if (channel(id) != ch) break;  // removed by a handler
  }
  if (--dispatching == 0 && !tombstoned.empty()) {
    for (uint16_t t : tombstoned) {
      if (Channel* c = channel(t)) compact(*c);
    }
    tombstoned.clear();
  }
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::setProps(Endpoint& e, uint16_t id, const Variant& props,
                                     std::string& why) {
  ErrorCode err = ErrorCode::ok;
  Channel* ch = owned(e, id, "changes the properties of", err, why);
  if (ch == nullptr) return err;
  const auto* map = props.asMap();
  if (map == nullptr) {
    why = "channel properties must be a map";
    return ErrorCode::invalid_argument;
  }
  PairDatabase* db = dbs.find(ch->name);
  for (const auto& [k, v] : *map) {
    if (v.isNull()) {
      db->remove(k);
    } else if (auto r = db->set(k, v); !r) {
      why = r.error().message;
      return ErrorCode::invalid_argument;
    }
  }
  forEachEventReceiver(*this, [&](Endpoint& r) { r.onChannelHeader(*ch); });
  return ErrorCode::ok;
}

}  // namespace skr::flow
