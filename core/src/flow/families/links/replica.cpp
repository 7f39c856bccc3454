// SPDX-License-Identifier: Apache-2.0
// Replicas (see replica.h).
#include "families/links/replica.h"

#include "hub.h"

#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {

Replica::Replica(Hub& hub, std::string owner_user, std::string short_name, std::string source,
                 uint32_t requester, std::shared_ptr<const AccessRules> rules)
    : hub_(hub),
      owner_user_(std::move(owner_user)),
      short_name_(std::move(short_name)),
      source_(std::move(source)),
      requester_(requester) {
  user = "replica/" + owner_user_;  // never an account; its channel is the owner user's
  client_name = "replica of " + source_;
  if (rules) access = std::move(rules);
  limits = access->limits().orElse(hub_.opt.user_limits);
  hub_.endpoints.add(*this);
}

Replica::~Replica() {
  hub_.removeEndpoint(*this);
}

void Replica::start() {
  if (const Channel* ch = hub_.channels.findByName(source_)) attach(*ch);
}

std::string Replica::describe() const {
  return "replica " + owner_user_ + "." + short_name_ + " of " + source_;
}

Variant Replica::propsOf(const Channel& source) const {
  Variant props = hub_.databases.channelProps(source.name);
  if (!props.isMap()) props = Variant::Map{};
  // A channel of this hub: the source's route (a far channel's) is not its own, and would keep
  // it from the hubs that route names.
  props.asMap()->erase("hub_route");
  (*props.asMap())["replica_of"] = Variant(source_);
  return props;
}

void Replica::attach(const Channel& source) {
  if (local_id_ != 0 || source.kind != ChannelKind::streaming) return;
  source_id_ = source.id;
  auto made = hub_.channels.createAs(*this, owner_user_, short_name_, ChannelKind::streaming,
                                     source.mime, propsOf(source), 0);
  if (!made) {
    log::warn(kLogSource, "FLOW-REPLICA", describe() + ": " + made.error().message);
    source_id_ = 0;
    return;
  }
  local_id_ = (*made)->id;
  // In-process subscribers waiting for this name came in createChannelAs, before local_id_ was
  // set: onSubscribers did not take them for ours.
  if ((*made)->subscriber_count > 0) subscribeSource();
}

void Replica::subscribeSource() {
  if (auto r = hub_.channels.subscribe(*this, source_id_); !r) {
    log::warn(kLogSource, "FLOW-REPLICA", describe() + ": " + r.error().message);
  }
}

void Replica::onChannelAdded(const Channel& ch, uint32_t) {
  if (ch.name == source_) attach(ch);
}

void Replica::onChannelRemoved(const Channel& ch) {
  if (ch.id != source_id_ || source_id_ == 0) return;
  source_id_ = 0;
  const uint16_t local = local_id_;
  local_id_ = 0;
  if (local != 0) (void)hub_.channels.remove(*this, local);
}

void Replica::onChannelHeader(const Channel& ch) {
  if (ch.id != source_id_ || local_id_ == 0) return;
  const Channel* local = hub_.channels.find(local_id_);
  if (local == nullptr) return;
  (void)hub_.databases.replaceChannelProps(local->name, *propsOf(ch).asMap());
}

void Replica::onSubscribers(const Channel& ch, bool first) {
  if (ch.id != local_id_ || source_id_ == 0) return;
  if (first) {
    subscribeSource();
  } else {
    (void)hub_.channels.unsubscribe(*this, source_id_);
  }
}

void Replica::onData(const Channel& ch, std::string_view payload) {
  if (ch.id != source_id_ || local_id_ == 0) return;
  ++traffic.messages_in;
  traffic.bytes_in += payload.size();
  (void)hub_.channels.publish(*this, local_id_, payload);
}

}  // namespace skr::flow
