// One connection for two hubs that list each other (see hub_link.h, docs/hub-links.md, "One
// connection"). The hub that dialled offers its channels over its connection (LINK_OFFER): the
// far hub makes them channels owned by that connection, and the ordinary owner's frames do the
// rest (first and last subscriber, PUBLISH, service requests and answers, CHAN_SET_PROPS,
// CHAN_REMOVE). The far hub's channels come the usual way, as a satellite sees them.
#include "connection.h"
#include "hub_link.h"
#include "hub_route.h"
#include "server_impl.h"

#include <skrobot/core/log.h>
#include <skrobot/satellite/satellite.h>

namespace skr::flow {

namespace {
constexpr const char* kLinkLog = "link";
// After the shared connection closed, the hub whose name sorts second waits this long before it
// dials, so that the two meet on the connection the first one opens.
constexpr Nanos kRedialAfter = 2 * kNsPerSec;

// What the far hub calls our channel `name`: ours get our prefix, a third hub's keep theirs.
std::string farName(const std::string& name, const std::string& own_hub) {
  return name.find('/') == std::string::npos ? own_hub + "/" + name : name;
}
}  // namespace

// --- the hub that was dialled ------------------------------------------------------------------

Result<void> HubLink::adopt(const Endpoint& c) {
  if (up_ && server_.hub_name < opt_.name) {
    return makeError(Errc::already_exists,
                     "hub " + server_.hub_name + " is linked to " + opt_.name +
                         " over the connection it opened: two hubs that list each other keep one");
  }
  shared_ = c.id;
  redial_at_ = 0;
  sat_->stop();  // our own connection, if any, goes: the far hub's is the link now
  state_ = "up (shared: the connection " + opt_.name + " opened)";
  since_ = utcNowText();
  log::info(kLinkLog, "HUB-LINK-SHARED",
            "hub " + opt_.name + " linked in: its connection is the link both ways");
  writeDb();
  return {};
}

void HubLink::released() {
  shared_ = 0;
  state_ = "down: hub " + opt_.name + " closed the shared connection";
  since_ = utcNowText();
  writeDb();
  // The channels it brought are gone: they may come another way, as when a link of ours drops.
  for (const auto& other : server_.links) {
    if (other.get() != this) other->offerAgain();
  }
  if (server_.hub_name < opt_.name) {
    sat_->start();
  } else {
    redial_at_ = monotonicNs() + kRedialAfter;
  }
}

HubLink* FlowServer::Impl::sharedLink(const Endpoint& c) {
  if (c.id == 0) return nullptr;
  for (const auto& link : links) {
    if (link->sharedConnection() == c.id) return link.get();
  }
  return nullptr;
}

Result<Channel*> FlowServer::Impl::linkOffer(Connection& c, const msg::LinkOffer& m) {
  HubLink* link = sharedLink(c);
  if (link == nullptr) {
    return makeError(Errc::invalid_argument,
                     "LINK_OFFER: this connection is not a link both hubs list");
  }
  const auto kind = static_cast<ChannelKind>(m.kind);
  if (kind != ChannelKind::streaming && kind != ChannelKind::service) {
    return makeError(Errc::invalid_argument, "only streaming and service channels cross a link");
  }
  const std::string name = linkedName(m.name, c.linked_hub, hub_name);
  if (name.empty()) {
    return makeError(Errc::invalid_argument, "\"" + m.name + "\" is not offered here");
  }
  const std::vector<std::string> route = hubRoute(m.props, c.linked_hub);
  if (!routeAccepted(route, hub_name, opt.link_hops)) {
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
  return createChannelAs(c, name.substr(0, dot), name.substr(dot + 1), kind, m.mime,
                         routedProps(m.props, route), m.tag);
}

// --- the hub that dialled: offers its channels -------------------------------------------------

void HubLink::offerAll() {
  if (!up_) return;
  offering_ = true;
  std::vector<const Channel*> all;
  server_.channels.forEach([&](const Channel& ch) { all.push_back(&ch); });
  for (const Channel* ch : all) offer(*ch);
}

void HubLink::offer(const Channel& ch) {
  if (!offering_ || !up_ || ch.owner == this) return;  // the far hub's own, brought by us
  if (ch.kind != ChannelKind::streaming && ch.kind != ChannelKind::service) return;
  if (ch.name.starts_with(opt_.name + "/") || offered_far_.contains(ch.id)) return;
  // Only what links[].account may use: the far hub does it as that account.
  const Action use = ch.kind == ChannelKind::streaming ? Action::subscribe : Action::call;
  if (!access->allows(use, ch.name)) return;
  const std::string far = farName(ch.name, server_.hub_name);
  if (offers_.contains(far)) return;
  msg::ChannelInfo info;
  info.kind = static_cast<uint8_t>(ch.kind);
  info.name = ch.name;
  info.mime = ch.mime;
  info.props = server_.databases.channelProps(ch.name);  // hub_route: the hops before us
  if (auto tag = sat_->offerChannel(info)) offers_[far] = Offer{ch.id, *tag, ch.name};
}

bool HubLink::offered(const msg::ChannelInfo& info) {
  if (info.owner_connection != sat_->login().connection_id) return false;
  auto it = offers_.find(info.name);
  if (it == offers_.end()) return true;  // ours over there, never taken back
  const Offer o = std::move(it->second);
  offers_.erase(it);
  const Channel* ch = server_.channels.find(o.local);
  if (ch == nullptr || ch->name != o.name) {
    (void)sat_->withdrawChannel(info.id);  // gone here while the offer travelled...
    // ...and perhaps made again meanwhile, not offered while this offer was pending.
    if (const Channel* again = server_.channels.findByName(o.name)) offer(*again);
    return true;
  }
  offered_far_[o.local] = info.id;
  offered_[info.id] = o.local;
  return true;
}

void HubLink::onChannelAdded(const Channel& ch, uint32_t) {
  offer(ch);
}

void HubLink::onChannelRemoved(const Channel& ch) {
  shownNoMore(ch);
  auto it = offered_far_.find(ch.id);
  if (it == offered_far_.end()) return;  // a pending offer is withdrawn when it is made
  (void)sat_->withdrawChannel(it->second);
  offered_.erase(it->second);
  offered_far_.erase(it);
}

void HubLink::onChannelHeader(const Channel& ch) {
  auto it = offered_far_.find(ch.id);
  if (it == offered_far_.end()) return;
  Variant props = server_.databases.channelProps(ch.name);
  if (auto* map = props.asMap()) {
    map->erase("hub_route");  // the far hub keeps the route it made
    (void)sat_->setChannelProperties(it->second, std::move(*map));
  }
}

void HubLink::farDemand(uint16_t far_id, bool first) {
  auto it = offered_.find(far_id);
  if (it == offered_.end()) return;
  if (first) {
    (void)server_.channels.subscribe(*this, it->second);
  } else {
    (void)server_.channels.unsubscribe(*this, it->second);
  }
}

void HubLink::onData(const Channel& ch, std::string_view payload) {
  auto it = offered_far_.find(ch.id);
  if (it == offered_far_.end()) return;
  ++traffic.messages_out;
  traffic.bytes_out += payload.size();
  (void)sat_->publish(it->second, payload);
}

void HubLink::farRequest(const msg::EvServiceRequest& r) {
  auto it = offered_.find(r.chan_id);
  if (it == offered_.end()) return;
  const uint32_t tag = next_tag_++;
  // Noted first: a module may answer from inside request() (onResponse).
  far_requests_[tag] = r;
  if (!server_.requests.request(*this, it->second, tag, false, 0, r.command, r.value)) {
    far_requests_.erase(tag);
  }
}

void HubLink::onResponse(uint16_t, uint32_t tag, bool, ErrorCode error, const Variant& value) {
  auto it = far_requests_.find(tag);
  if (it == far_requests_.end()) return;
  // A failure here is the far caller's timeout, or owner_gone when the channel goes with it.
  if (error == ErrorCode::ok) (void)sat_->respond(it->second, value);
  far_requests_.erase(it);
}

void HubLink::stopOffering() {
  offering_ = false;
  for (const auto& [local, far] : offered_far_) (void)server_.channels.unsubscribe(*this, local);
  offers_.clear();
  offered_far_.clear();
  offered_.clear();
  far_requests_.clear();
}

}  // namespace skr::flow
