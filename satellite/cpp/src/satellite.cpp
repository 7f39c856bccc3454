// SPDX-License-Identifier: Apache-2.0
// Satellite's public methods: channels, publishing, services, databases.
#include "satellite_impl.h"

#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/channel_type.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>

namespace skr::sat {

namespace msg = flow::msg;
using flow::Variant;

Result<SatelliteOptions> SatelliteOptions::fromEnvironment(std::string client_name) {
  auto c = ConnectOptions::fromEnvironment(std::move(client_name));
  if (!c) return c.error();
  SatelliteOptions o;
  o.connection = std::move(c).value();
  if (const char* tcp = std::getenv("ROBOT_PATH_TCP"); tcp != nullptr) o.path_tcp = tcp;
  return o;
}

namespace {

Error notConnected() {
  return makeError(Errc::closed, "not connected to the hub");
}

}  // namespace

Satellite::Satellite(Loop& loop, SatelliteOptions options)
    : Object(loop), impl_(std::make_unique<Impl>(*this, std::move(options))) {
  onTick(Tick::one_sec, [this] { impl_->onOneSecond(); });
}

Satellite::~Satellite() {
  impl_.reset();
}

void Satellite::start() {
  impl_->start();
}
void Satellite::stop() {
  impl_->stop();
}
bool Satellite::isConnected() const noexcept {
  return impl_->flowOpen();
}
const SatelliteOptions& Satellite::options() const noexcept {
  return impl_->opt;
}
const LoginInfo& Satellite::login() const noexcept {
  return impl_->login;
}
const std::string& Satellite::linkedHub() const noexcept {
  return impl_->linked_hub;
}
const SatelliteStats& Satellite::stats() const noexcept {
  if (impl_->link != nullptr) impl_->stats.writes = impl_->link->writes();
  return impl_->stats;
}

Satellite::Impl::Own* Satellite::Impl::findOwn(std::string_view name) {
  if (auto it = own.find(name); it != own.end()) return &it->second;
  const std::string prefix = login.user + ".";
  if (name.starts_with(prefix)) {
    if (auto it = own.find(name.substr(prefix.size())); it != own.end()) return &it->second;
  }
  return nullptr;
}
const Satellite::Impl::Own* Satellite::Impl::findOwn(std::string_view name) const {
  return const_cast<Impl*>(this)->findOwn(name);
}

// --- channels -----------------------------------------------------------------------------------

Result<void> Satellite::addChannel(ChannelSpec spec) {
  if (!flow::validShortName(spec.name)) {
    return makeError(
        Errc::invalid_argument,
        "bad channel name \"" + spec.name + "\": 1-128 of A-Z a-z 0-9 _ - . not starting with '.'");
  }
  if (!spec.props.isMap() && !spec.props.isNull()) {
    return makeError(Errc::invalid_argument, "channel properties must be a map");
  }
  // A typed channel's type (docs/channels.md, "Typed channels") must follow the rules.
  if (spec.props.isMap()) {
    namespace ct = skr::channel_type;
    auto text = [&](std::string_view key) {
      const flow::Variant* v = spec.props.find(std::string(key));
      return v != nullptr && v->asString() != nullptr ? *v->asString() : std::string();
    };
    const ct::ChannelType type{text(ct::kMessageEncodingKey), text(ct::kSchemaNameKey),
                               text(ct::kSchemaEncodingKey), text(ct::kSchemaKey)};
    if (auto bad = ct::check(type)) {
      return makeError(Errc::invalid_argument, "channel " + spec.name + "'s type: " + *bad);
    }
  }
  if (impl_->own.contains(spec.name)) {
    return makeError(Errc::already_exists, "channel " + spec.name + " was added already");
  }
  const std::string name = spec.name;
  auto& o = impl_->own[name];
  o.spec = std::move(spec);
  if (impl_->flowOpen()) impl_->sendChanAdd(o);
  return {};
}

Result<void> Satellite::removeChannel(std::string_view name) {
  Impl::Own* o = impl_->findOwn(name);
  if (o == nullptr)
    return makeError(Errc::not_found, "no channel of ours named " + std::string(name));
  if (o->id != 0 && impl_->flowOpen()) impl_->send(msg::ChanRemove{impl_->nextTag(), o->id});
  if (o->tag != 0) impl_->orphan_tags.push_back(o->tag);  // removed once the hub made it
  impl_->own.erase(o->spec.name);
  return {};
}

Result<void> Satellite::setChannelProperties(std::string_view name, Variant::Map props) {
  Impl::Own* o = impl_->findOwn(name);
  if (o == nullptr)
    return makeError(Errc::not_found, "no channel of ours named " + std::string(name));
  if (!o->spec.props.isMap()) o->spec.props = Variant::Map{};
  auto& mine = *o->spec.props.asMap();
  for (const auto& [key, value] : props) {
    if (value.isNull()) {
      mine.erase(key);
    } else {
      mine[key] = value;
    }
  }
  if (o->id != 0 && impl_->flowOpen()) {
    impl_->send(msg::ChanSetProps{impl_->nextTag(), o->id, Variant(std::move(props))});
  }
  return {};
}

const ChannelInfo* Satellite::channel(uint16_t chan_id) const {
  auto it = impl_->table.find(chan_id);
  return it == impl_->table.end() ? nullptr : &it->second;
}

const ChannelInfo* Satellite::channel(std::string_view name) const {
  auto id = channelId(name);
  return id ? channel(*id) : nullptr;
}

std::optional<uint16_t> Satellite::channelId(std::string_view name) const {
  if (auto it = impl_->by_name.find(name); it != impl_->by_name.end()) return it->second;
  if (const Impl::Own* o = impl_->findOwn(name); o != nullptr && o->id != 0) return o->id;
  return std::nullopt;
}

std::vector<ChannelInfo> Satellite::channels() const {
  std::vector<ChannelInfo> out;
  out.reserve(impl_->table.size());
  for (const auto& [id, info] : impl_->table) out.push_back(info);
  return out;
}

bool Satellite::hasSubscribers(std::string_view name) const {
  const Impl::Own* o = impl_->findOwn(name);
  return o != nullptr && o->id != 0 && o->subscribers;
}

void Satellite::subscribe(std::string name) {
  const auto [entry, added] = impl_->subs.emplace(std::move(name), 0);
  if (!added || !impl_->flowOpen()) return;
  const std::string& n = entry->first;
  if (auto it = impl_->by_name.find(n); it != impl_->by_name.end()) impl_->attach(n, it->second);
}

void Satellite::subscribe(std::string name, size_t queue_bytes) {
  subscribe(std::move(name), queue_bytes, 0);
}

void Satellite::subscribe(std::string name, size_t queue_bytes, uint16_t max_hz) {
  const Impl::Ask ask{static_cast<uint32_t>(std::min<size_t>(queue_bytes, UINT32_MAX)), max_hz};
  auto q = impl_->queues.find(name);
  if (q != impl_->queues.end() && q->second == ask) return;
  impl_->queues.insert_or_assign(name, ask);
  auto s = impl_->subs.find(name);
  if (s != impl_->subs.end() && s->second != 0) {  // attached: the new request at once
    if (impl_->flowOpen()) impl_->sendSubscribe(s->second, ask);
    return;
  }
  subscribe(std::move(name));  // attach() asks for the queue and the rate
}

void Satellite::Impl::sendSubscribe(uint16_t id, const Ask& ask) {
  if (ask.max_hz != 0 && login.minor >= 14) {
    send(msg::SubscribeRate{nextTag(), id, ask.queue_bytes, ask.max_hz});
  } else if (login.minor >= 13) {
    send(msg::SubscribeQueue{nextTag(), id, ask.queue_bytes});
  } else {
    send(msg::Subscribe{nextTag(), id});
  }
}

Result<void> Satellite::subscribe(uint16_t chan_id) {
  const ChannelInfo* info = channel(chan_id);
  if (info == nullptr)
    return makeError(Errc::not_found, "no channel with id " + std::to_string(chan_id));
  subscribe(std::string(info->name));
  return {};
}

void Satellite::unsubscribe(std::string_view name) {
  auto it = impl_->subs.find(name);
  if (it == impl_->subs.end()) return;
  if (it->second != 0 && impl_->flowOpen()) {
    impl_->paths->onUnsubscribed(it->second);
    impl_->send(msg::Unsubscribe{impl_->nextTag(), it->second});
  }
  if (auto q = impl_->queues.find(name); q != impl_->queues.end()) impl_->queues.erase(q);
  impl_->subs.erase(it);
}

void Satellite::usePaths(std::string name, uint8_t kinds) {
  usePaths(std::move(name), kinds, PathWait::wake);
}

void Satellite::usePaths(std::string name, uint8_t kinds, PathWait wait) {
  impl_->paths->want(name, kinds, wait == PathWait::spin);
  auto s = impl_->subs.find(name);
  if (s != impl_->subs.end() && s->second != 0 && impl_->flowOpen() && impl_->login.minor >= 7) {
    impl_->paths->onSubscribed(name, s->second);
  }
}

void Satellite::resetPaths() {
  impl_->paths->closeAll("reset by the application");
}

Satellite::PathStats Satellite::pathStats() const {
  const auto s = impl_->paths->stats();
  return PathStats{s.served_direct, s.served_shm, s.path_messages, s.dropped_before_marker,
                   s.torn,          s.fallbacks,  s.missed,        s.polled};
}

void Satellite::follow(std::string name, uint32_t every) {
  auto f = impl_->follows.find(name);
  if (f != impl_->follows.end() && f->second == every) return;
  impl_->follows[name] = every;
  auto s = impl_->subs.find(name);
  if (s != impl_->subs.end() && s->second != 0) {
    if (impl_->flowOpen()) impl_->send(msg::SyncFollow{impl_->nextTag(), s->second, every});
    return;
  }
  subscribe(std::move(name));  // attach() follows what `follows` names
}

void Satellite::unfollow(std::string_view name) {
  auto f = impl_->follows.find(name);
  if (f == impl_->follows.end()) return;
  auto s = impl_->subs.find(name);
  if (s != impl_->subs.end()) {
    if (s->second != 0 && impl_->flowOpen()) {
      impl_->send(msg::SyncUnfollow{impl_->nextTag(), s->second});
    }
    impl_->subs.erase(s);
  }
  impl_->follows.erase(f);
}

Result<void> Satellite::pulse(std::string_view name) {
  if (!impl_->flowOpen()) return notConnected();
  const Impl::Own* o = impl_->findOwn(name);
  if (o == nullptr || o->id == 0 || o->spec.kind != flow::ChannelKind::sync) {
    return makeError(Errc::not_found, "no sync source of ours named " + std::string(name));
  }
  impl_->send(msg::SyncPulse{o->id, static_cast<uint64_t>(monotonicNs())});
  return {};
}

bool Satellite::isSubscribed(std::string_view name) const {
  auto it = impl_->subs.find(name);
  return it != impl_->subs.end() && it->second != 0;
}

Result<void> Satellite::publish(uint16_t chan_id, std::string_view payload) {
  if (!impl_->flowOpen()) return notConnected();
  auto it = impl_->table.find(chan_id);
  if (it == impl_->table.end() || it->second.owner_connection != impl_->login.connection_id) {
    return makeError(Errc::not_found, "no channel of ours with id " + std::to_string(chan_id));
  }
  if (impl_->link->pendingBytes() + payload.size() > impl_->opt.max_queued_bytes) {
    return makeError(Errc::limit_exceeded, "the outgoing queue is full (" +
                                               std::to_string(impl_->link->pendingBytes()) +
                                               " bytes wait): frame dropped");
  }
  // Our paths first; the hub only while someone is relayed.
  if (!impl_->paths->publish(chan_id, payload, 0)) return {};
  impl_->send(msg::Publish{chan_id, msg::Rest{payload}});
  return {};
}

std::span<std::byte> Satellite::beginPublish(std::string_view name) {
  const Impl::Own* o = impl_->findOwn(name);
  if (o == nullptr || o->id == 0 || !impl_->flowOpen()) return {};
  return impl_->paths->beginPublish(o->id);
}

Result<void> Satellite::commitPublish(std::string_view name, size_t size, int64_t capture_ns) {
  const Impl::Own* o = impl_->findOwn(name);
  if (o == nullptr || o->id == 0) {
    if (!impl_->flowOpen()) return notConnected();
    return makeError(Errc::not_found, "no channel of ours named " + std::string(name) + " yet");
  }
  bool relay = true;
  auto bytes = impl_->paths->commitPublish(o->id, size, capture_ns, relay);
  if (!bytes)
    return makeError(Errc::invalid_argument, "commitPublish without a slot from beginPublish");
  if (relay && impl_->flowOpen()) impl_->send(msg::Publish{o->id, msg::Rest{*bytes}});
  return {};
}

Result<void> Satellite::publish(std::string_view name, std::string_view payload) {
  const Impl::Own* o = impl_->findOwn(name);
  if (o == nullptr || o->id == 0) {
    if (!impl_->flowOpen()) return notConnected();
    return makeError(Errc::not_found, "no channel of ours named " + std::string(name) + " yet");
  }
  return publish(o->id, payload);
}

size_t Satellite::queuedBytes() const noexcept {
  return impl_->link != nullptr ? impl_->link->pendingBytes() : 0;
}

}  // namespace skr::sat
