// SPDX-License-Identifier: Apache-2.0
// The channel table and the router (see channel_table.h).
#include "families/channels/channel_table.h"

#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {

ChannelTable::ChannelTable(Nanos (*clock)()) : rng_(std::random_device{}()), clock_(clock) {
  channels_.resize(kMaxChannels);
}

Channel* ChannelTable::findByName(const std::string& name) noexcept {
  auto it = by_name_.find(name);
  return it == by_name_.end() ? nullptr : find(it->second);
}

Result<Channel*> ChannelTable::existing(uint16_t id) {
  Channel* ch = find(id);
  if (ch == nullptr) return makeError(Errc::not_found, "no channel with id " + std::to_string(id));
  return ch;
}

Result<Channel*> ChannelTable::owned(const Endpoint& e, uint16_t id, const char* action) {
  auto ch = existing(id);
  // A blob channel is its user's, whichever connection made it; a far one, its link's.
  const auto owns = [&e](const Channel& c) {
    return c.kind == ChannelKind::blob && !c.far ? c.owner_user == e.user : c.owner == &e;
  };
  if (ch && !owns(**ch)) {
    return makeError(Errc::permission_denied,
                     std::string("only the owner ") + action + " " + (*ch)->name);
  }
  return ch;
}

Result<Channel*> ChannelTable::add(Endpoint* owner, const std::string& user,
                                   const std::string& short_name, ChannelKind kind,
                                   const std::string& mime) {
  if (!flow::validShortName(short_name)) {
    return makeError(Errc::invalid_argument,
                     "channel name \"" + short_name +
                         "\": 1 to 128 of A-Z a-z 0-9 _ - . (not starting with '.')");
  }
  if (kind != ChannelKind::streaming && kind != ChannelKind::service && kind != ChannelKind::blob &&
      kind != ChannelKind::sync) {
    return makeError(Errc::invalid_argument, "unknown channel kind");
  }
  std::string name = user + "." + short_name;
  if (by_name_.count(name) != 0) {
    return makeError(Errc::already_exists, "channel " + name + " exists");
  }
  if (count_ >= kMaxChannels - 1) {
    return makeError(Errc::limit_exceeded, "the hub holds its maximum of channels");
  }
  uint16_t id = next_hint_;
  while (channels_[id] != nullptr || id == 0) id = static_cast<uint16_t>((id + 1) % kMaxChannels);
  next_hint_ = static_cast<uint16_t>((id + 1) % kMaxChannels);

  auto ch = std::make_unique<Channel>();
  ch->id = id;
  ch->hash = rng_() | 1;  // never 0
  ch->kind = kind;
  ch->name = std::move(name);
  ch->mime = mime;
  ch->owner = owner;
  ch->owner_user = user;
  ch->rates = Channel::Rates(clock_(), ch->rateCounters());
  Channel* raw = ch.get();
  channels_[id] = std::move(ch);
  by_name_[raw->name] = id;
  ++count_;
  if (owner != nullptr) owner->owned.push_back(id);
  return raw;
}

std::unique_ptr<Channel> ChannelTable::erase(Channel& ch) {
  const uint16_t id = ch.id;
  for (Endpoint* s : ch.subscribers) {
    if (s != nullptr) std::erase(s->subscribed, id);
  }
  for (Endpoint* s : ch.physical) std::erase(s->subscribed, id);
  if (ch.owner != nullptr) std::erase(ch.owner->owned, id);
  std::unique_ptr<Channel> gone = std::move(channels_[id]);
  by_name_.erase(gone->name);
  --count_;
  return gone;
}

Result<void> ChannelTable::subscribe(Endpoint& e, uint16_t id) {
  auto found = existing(id);
  if (!found) return found.error();
  Channel* ch = *found;
  if (ch->kind == ChannelKind::service) {
    return makeError(Errc::invalid_argument, ch->name + " is a service channel: call it");
  }
  if (ch->kind == ChannelKind::sync) {
    return makeError(Errc::invalid_argument, ch->name + " is a sync source: follow it");
  }
  if (!e.access->allows(Action::subscribe, ch->name)) {
    return accessDenied(e.user, Action::subscribe, ch->name);
  }
  if (std::find(ch->subscribers.begin(), ch->subscribers.end(), &e) != ch->subscribers.end() ||
      std::find(ch->physical.begin(), ch->physical.end(), &e) != ch->physical.end()) {
    return {};  // already subscribed
  }
  ch->subscribers.push_back(&e);
  e.subscribed.push_back(id);
  if (++ch->subscriber_count == 1 && ch->owner != nullptr &&
      (ch->kind == ChannelKind::streaming || ch->far)) {
    ch->owner->onSubscribers(*ch, true);
  }
  if (!ch->retained.empty()) {
    // The retained messages, before anything live; a handler may unsubscribe, remove the channel
    // or retain more (the copy of the list keeps these alive).
    const auto kept = ch->retained;
    for (const auto& [key, payload] : kept) {
      if (find(id) != ch ||
          std::find(e.subscribed.begin(), e.subscribed.end(), id) == e.subscribed.end()) {
        break;
      }
      e.onData(*ch, *payload);
    }
  }
  return {};
}

Result<void> ChannelTable::unsubscribe(Endpoint& e, uint16_t id) {
  auto found = existing(id);
  if (!found) return found.error();
  Channel* ch = *found;
  auto it = std::find(ch->subscribers.begin(), ch->subscribers.end(), &e);
  if (it != ch->subscribers.end()) {
    if (dispatching_ > 0) {
      *it = nullptr;  // tombstone: a publish is iterating this list
      tombstoned_.push_back(id);
    } else {
      ch->subscribers.erase(it);
    }
  } else if (std::erase(ch->physical, &e) == 0) {
    return {};
  }
  std::erase(e.subscribed, id);
  // A far blob channel's link follows its changes over there while someone here subscribes.
  if (--ch->subscriber_count == 0 && ch->owner != nullptr && ch->owner != &e &&
      (ch->kind == ChannelKind::streaming || ch->far)) {
    ch->owner->onSubscribers(*ch, false);
  }
  return {};
}

void ChannelTable::setPhysical(Endpoint& e, uint16_t id, bool physical) {
  Channel* ch = find(id);
  if (ch == nullptr) return;
  if (physical) {
    auto it = std::find(ch->subscribers.begin(), ch->subscribers.end(), &e);
    if (it == ch->subscribers.end()) return;
    if (dispatching_ > 0) {
      *it = nullptr;
      tombstoned_.push_back(id);
    } else {
      ch->subscribers.erase(it);
    }
    ch->physical.push_back(&e);
  } else if (std::erase(ch->physical, &e) > 0) {
    ch->subscribers.push_back(&e);
  }
}

namespace {
Result<Channel*> streaming(ChannelTable& t, uint16_t id) {
  Channel* ch = t.find(id);
  if (ch == nullptr || ch->kind != ChannelKind::streaming) {
    return makeError(Errc::not_found, "no streaming channel with id " + std::to_string(id));
  }
  return ch;
}
void stopKeeping(Channel& ch) {
  std::string().swap(ch.last);
  ch.last_seq = 0;
}
}  // namespace

Result<void> ChannelTable::pollRegister(uint32_t endpoint, uint16_t id) {
  auto ch = streaming(*this, id);
  if (!ch) return ch.error();
  auto& p = (*ch)->pollers;
  if (std::find(p.begin(), p.end(), endpoint) == p.end()) p.push_back(endpoint);
  return {};
}

Result<std::pair<uint64_t, std::string_view>> ChannelTable::pollFetch(uint16_t id) {
  auto ch = streaming(*this, id);
  if (!ch) return ch.error();
  return std::pair<uint64_t, std::string_view>{(*ch)->last_seq, (*ch)->last};
}

Result<void> ChannelTable::pollDeregister(uint32_t endpoint, uint16_t id) {
  auto ch = streaming(*this, id);
  if (!ch) return ch.error();
  auto& p = (*ch)->pollers;
  auto it = std::find(p.begin(), p.end(), endpoint);
  if (it == p.end()) {
    return makeError(Errc::not_found, "this client does not poll " + (*ch)->name);
  }
  p.erase(it);
  if (p.empty()) stopKeeping(**ch);
  return {};
}

void ChannelTable::unpollAll(uint32_t endpoint) {
  for (auto& ch : channels_) {
    if (ch != nullptr && std::erase(ch->pollers, endpoint) > 0 && ch->pollers.empty()) {
      stopKeeping(*ch);
    }
  }
}

void ChannelTable::compact(Channel& ch) {
  std::erase(ch.subscribers, nullptr);
}

Result<void> ChannelTable::publish(Endpoint& e, uint16_t id, std::string_view payload) {
  auto found = owned(e, id, "publishes to");
  if (!found) return found.error();
  Channel* ch = *found;
  if (ch->kind != ChannelKind::streaming) {
    return makeError(Errc::invalid_argument, ch->name + " is not a streaming channel");
  }
  ++ch->seq;
  ch->bytes += payload.size();
  if (!ch->pollers.empty()) {
    ch->last.assign(payload);
    ch->last_seq = ch->seq;
  }
  ++dispatching_;
  // Index loop: a local handler may subscribe (appends) or unsubscribe (tombstones).
  for (size_t i = 0; i < ch->subscribers.size(); ++i) {
    if (Endpoint* s = ch->subscribers[i]) s->onData(*ch, payload);
    if (find(id) != ch) break;  // removed by a handler
  }
  if (--dispatching_ == 0 && !tombstoned_.empty()) {
    for (uint16_t t : tombstoned_) {
      if (Channel* c = find(t)) compact(*c);
    }
    tombstoned_.clear();
  }
  return {};
}

Result<void> ChannelTable::publishRetained(Endpoint& e, uint16_t id, std::string_view key,
                                           std::string_view payload) {
  if (key.empty() || key.size() > kMaxRetainedKeyBytes) {
    return makeError(Errc::invalid_argument, "a retained message's key has 1 to " +
                                                 std::to_string(kMaxRetainedKeyBytes) + " bytes");
  }
  auto found = owned(e, id, "publishes to");
  if (!found) return found.error();
  Channel* ch = *found;
  if (ch->kind != ChannelKind::streaming) {
    return makeError(Errc::invalid_argument, ch->name + " is not a streaming channel");
  }
  auto& kept = ch->retained;
  auto it = std::find_if(kept.begin(), kept.end(), [&](const auto& k) { return k.first == key; });
  const size_t replaced = it != kept.end() ? it->second->size() : 0;
  if (it == kept.end() && kept.size() >= kMaxRetainedKeys) {
    return makeError(Errc::limit_exceeded, ch->name + " retains " +
                                               std::to_string(kMaxRetainedKeys) +
                                               " messages already (one per key)");
  }
  if (ch->retained_bytes - replaced + payload.size() > kMaxRetainedBytes) {
    return makeError(Errc::limit_exceeded, ch->name + " would retain more than " +
                                               std::to_string(kMaxRetainedBytes >> 20) + " MiB");
  }
  if (it != kept.end()) kept.erase(it);
  kept.emplace_back(std::string(key), std::make_shared<const std::string>(payload));
  ch->retained_bytes = ch->retained_bytes - replaced + payload.size();
  return publish(e, id, payload);
}

Result<void> ChannelTable::clearRetained(Endpoint& e, uint16_t id,
                                         std::optional<std::string_view> key) {
  auto found = owned(e, id, "clears");
  if (!found) return found.error();
  Channel* ch = *found;
  if (!key) {
    ch->retained.clear();
    ch->retained_bytes = 0;
    return {};
  }
  auto& kept = ch->retained;
  auto it = std::find_if(kept.begin(), kept.end(), [&](const auto& k) { return k.first == *key; });
  if (it == kept.end()) {
    return makeError(Errc::not_found, ch->name + " retains nothing under " + std::string(*key));
  }
  ch->retained_bytes -= it->second->size();
  kept.erase(it);
  return {};
}

void ChannelTable::want(const std::string& name, uint32_t endpoint) {
  auto [lo, hi] = wanted_.equal_range(name);
  for (auto it = lo; it != hi; ++it) {
    if (it->second == endpoint) return;
  }
  wanted_.emplace(name, endpoint);
}

void ChannelTable::unwant(const std::string& name, uint32_t endpoint) {
  auto [lo, hi] = wanted_.equal_range(name);
  for (auto it = lo; it != hi;) it = it->second == endpoint ? wanted_.erase(it) : std::next(it);
}

void ChannelTable::unwantAll(uint32_t endpoint) {
  for (auto it = wanted_.begin(); it != wanted_.end();) {
    it = it->second == endpoint ? wanted_.erase(it) : std::next(it);
  }
}

std::vector<uint32_t> ChannelTable::wanting(const std::string& name) const {
  std::vector<uint32_t> ids;
  auto [lo, hi] = wanted_.equal_range(name);
  for (auto it = lo; it != hi; ++it) ids.push_back(it->second);
  return ids;
}

}  // namespace skr::flow
