// Replicas (see replica.h).
#include "replica.h"

#include "server_impl.h"

#include <skrobot/core/log.h>
#include <skrobot/flow/name_pattern.h>

#include <algorithm>

namespace skr::flow {

Replica::Replica(FlowServer::Impl& server, std::string owner_user, std::string short_name,
                 std::string source, uint32_t requester, std::shared_ptr<const AccessRules> rules)
    : server_(server),
      owner_user_(std::move(owner_user)),
      short_name_(std::move(short_name)),
      source_(std::move(source)),
      requester_(requester) {
  user = "replica/" + owner_user_;  // never an account; its channel is the owner user's
  client_name = "replica of " + source_;
  if (rules) access = std::move(rules);
  limits = access->limits().orElse(server_.opt.user_limits);
  server_.endpoints.add(*this);
}

Replica::~Replica() {
  server_.removeEndpoint(*this);
}

void Replica::start() {
  if (const Channel* ch = server_.channels.findByName(source_)) attach(*ch);
}

std::string Replica::describe() const {
  return "replica " + owner_user_ + "." + short_name_ + " of " + source_;
}

Variant Replica::propsOf(const Channel& source) const {
  Variant props = server_.databases.channelProps(source.name);
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
  auto made = server_.createChannelAs(*this, owner_user_, short_name_, ChannelKind::streaming,
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
  if (auto r = server_.channels.subscribe(*this, source_id_); !r) {
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
  if (local != 0) (void)server_.removeChannel(*this, local);
}

void Replica::onChannelHeader(const Channel& ch) {
  if (ch.id != source_id_ || local_id_ == 0) return;
  const Channel* local = server_.channels.find(local_id_);
  if (local == nullptr) return;
  (void)server_.databases.replaceChannelProps(local->name, *propsOf(ch).asMap());
}

void Replica::onSubscribers(const Channel& ch, bool first) {
  if (ch.id != local_id_ || source_id_ == 0) return;
  if (first) {
    subscribeSource();
  } else {
    (void)server_.channels.unsubscribe(*this, source_id_);
  }
}

void Replica::onData(const Channel& ch, std::string_view payload) {
  if (ch.id != source_id_ || local_id_ == 0) return;
  ++traffic.messages_in;
  traffic.bytes_in += payload.size();
  (void)server_.channels.publish(*this, local_id_, payload);
}

// --- the server's side -------------------------------------------------------------------------

Result<void> FlowServer::Impl::replicate(const std::string& owner_user, const std::string& source,
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
  if (const Channel* ch = channels.findByName(source); ch && ch->kind != ChannelKind::streaming) {
    return makeError(Errc::invalid_argument, source + " is not a streaming channel");
  }
  for (const auto& r : replicas) {
    if (r->ownerUser() == owner_user && r->shortName() == short_name) {
      return makeError(Errc::already_exists, "a replica " + name + " exists");
    }
  }
  if (channels.findByName(name) != nullptr) {
    return makeError(Errc::already_exists, "channel " + name + " exists");
  }
  replicas.push_back(std::make_unique<Replica>(*this, owner_user, short_name, source,
                                               by != nullptr ? by->id : 0,
                                               by != nullptr ? by->access : nullptr));
  replicas.back()->start();
  log::info(kLogSource, "FLOW-REPLICA", replicas.back()->describe() + " created");
  return {};
}

Result<void> FlowServer::Impl::stopReplica(const std::string& owner_user,
                                           const std::string& short_name, uint32_t by) {
  const auto it = std::find_if(replicas.begin(), replicas.end(), [&](const auto& r) {
    return r->ownerUser() == owner_user && r->shortName() == short_name && r->requester() == by;
  });
  if (it == replicas.end()) {
    return makeError(Errc::not_found, "no replica " + owner_user + "." + short_name + " of yours");
  }
  std::unique_ptr<Replica> gone = std::move(*it);
  replicas.erase(it);
  return {};
}

void FlowServer::Impl::dropReplicasOf(uint32_t requester) {
  std::vector<std::unique_ptr<Replica>> gone;
  for (auto it = replicas.begin(); it != replicas.end();) {
    if ((*it)->requester() == requester) {
      gone.push_back(std::move(*it));
      it = replicas.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace skr::flow
