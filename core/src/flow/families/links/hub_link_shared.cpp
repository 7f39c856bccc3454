// SPDX-License-Identifier: Apache-2.0
// One connection for two hubs that list each other (see hub_link.h, docs/hub-links.md, "One
// connection"). The hub that dialled offers its channels over its connection (LINK_OFFER): the
// far hub makes them channels owned by that connection, and the ordinary owner's frames do the
// rest (first and last subscriber, PUBLISH, service requests and answers, CHAN_SET_PROPS,
// CHAN_REMOVE). The far hub's channels come the usual way, as a satellite sees them.
#include "connection.h"
#include "families/links/hub_link.h"
#include "families/links/hub_route.h"
#include "hub.h"

#include <skrobot/runtime/log.h>
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
  if (up_ && hub_.hub_name < opt_.name) {
    return makeError(Errc::already_exists,
                     "hub " + hub_.hub_name + " is linked to " + opt_.name +
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
  for (const auto& other : hub_.links.all()) {
    if (other.get() != this) other->offerAgain();
  }
  if (hub_.hub_name < opt_.name) {
    sat_->start();
  } else {
    redial_at_ = monotonicNs() + kRedialAfter;
  }
}

// --- the hub that dialled: offers its channels -------------------------------------------------

void HubLink::offerAll() {
  if (!up_) return;
  offering_ = true;
  std::vector<const Channel*> all;
  hub_.channels.forEach([&](const Channel& ch) { all.push_back(&ch); });
  for (const Channel* ch : all) offer(*ch);
}

void HubLink::offer(const Channel& ch) {
  if (!offering_ || !up_ || ch.owner == this) return;  // the far hub's own, brought by us
  if (ch.kind != ChannelKind::streaming && ch.kind != ChannelKind::service) return;
  if (ch.name.starts_with(opt_.name + "/") || offered_far_.contains(ch.id)) return;
  // Only what links[].account may use: the far hub does it as that account.
  const Action use = ch.kind == ChannelKind::streaming ? Action::subscribe : Action::call;
  if (!access->allows(use, ch.name)) return;
  const std::string far = farName(ch.name, hub_.hub_name);
  if (offers_.contains(far)) return;
  msg::ChannelInfo info;
  info.kind = static_cast<uint8_t>(ch.kind);
  info.name = ch.name;
  info.mime = ch.mime;
  info.props = hub_.databases.channelProps(ch.name);  // hub_route: the hops before us
  if (auto tag = sat_->offerChannel(info)) offers_[far] = Offer{ch.id, *tag, ch.name};
}

bool HubLink::offered(const msg::ChannelInfo& info) {
  if (info.owner_connection != sat_->login().connection_id) return false;
  auto it = offers_.find(info.name);
  if (it == offers_.end()) return true;  // ours over there, never taken back
  const Offer o = std::move(it->second);
  offers_.erase(it);
  const Channel* ch = hub_.channels.find(o.local);
  if (ch == nullptr || ch->name != o.name) {
    (void)sat_->withdrawChannel(info.id);  // gone here while the offer travelled...
    // ...and perhaps made again meanwhile, not offered while this offer was pending.
    if (const Channel* again = hub_.channels.findByName(o.name)) offer(*again);
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
  Variant props = hub_.databases.channelProps(ch.name);
  if (auto* map = props.asMap()) {
    map->erase("hub_route");  // the far hub keeps the route it made
    (void)sat_->setChannelProperties(it->second, std::move(*map));
  }
}

void HubLink::farDemand(uint16_t far_id, bool first) {
  auto it = offered_.find(far_id);
  if (it == offered_.end()) return;
  if (first) {
    (void)hub_.channels.subscribe(*this, it->second);
  } else {
    (void)hub_.channels.unsubscribe(*this, it->second);
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
  if (!hub_.services.request(*this, it->second, tag, false, 0, r.command, r.value)) {
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
  for (const auto& [local, far] : offered_far_) (void)hub_.channels.unsubscribe(*this, local);
  offers_.clear();
  offered_far_.clear();
  offered_.clear();
  far_requests_.clear();
}

}  // namespace skr::flow
