// SPDX-License-Identifier: Apache-2.0
// Physical mode's grants (see physical_paths.h).
#include "families/physical/physical_paths.h"

#include <skrobot/hub/flow/access.h>
#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/log.h>

#include <sodium.h>

#include <algorithm>

namespace skr::flow {
namespace {

// 128 random bits as 32 hex digits: what the subscriber presents to the owner, once.
std::string newToken() {
  unsigned char raw[16];
  (void)sodiumReady();
  randombytes_buf(raw, sizeof raw);
  char hex[sizeof raw * 2 + 1];
  sodium_bin2hex(hex, sizeof hex, raw, sizeof raw);
  return hex;
}

bool startsWith(const std::string& s, std::string_view prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

}  // namespace

Result<void> PhysicalPaths::offer(Endpoint& e, const msg::PhysOffer& m) {
  auto owned = channels_.owned(e, m.chan_id, "offers paths to");
  if (!owned) return owned.error();
  Channel& ch = **owned;
  if (ch.kind != ChannelKind::streaming) {
    return makeError(Errc::invalid_argument, ch.name + " is not a streaming channel");
  }
  if (m.paths == 0) {
    dropChannel(m.chan_id);
    log::info(kLogSource, "PHYS-OFFER", ch.name + ": paths withdrawn");
    return {};
  }
  if ((m.paths & ~(msg::kPhysDirect | msg::kPhysShm)) != 0) {
    return makeError(Errc::invalid_argument, "unknown path kinds in PHYS_OFFER");
  }
  // One endpoint, or (1.8) a unix: and a tcp: endpoint separated by a space.
  std::string unix_ep, tcp_ep;
  for (size_t at = 0; at <= m.endpoint.size();) {
    size_t end = m.endpoint.find(' ', at);
    if (end == std::string::npos) end = m.endpoint.size();
    const std::string one = m.endpoint.substr(at, end - at);
    std::string& slot = startsWith(one, "unix:") ? unix_ep : tcp_ep;
    const size_t scheme = startsWith(one, "unix:") ? 5 : 4;
    if ((!startsWith(one, "unix:") && !startsWith(one, "tcp:")) || one.size() <= scheme ||
        !slot.empty()) {
      return makeError(Errc::invalid_argument,
                       "a path endpoint is unix:<path> or tcp:<host>:<port>, or one of each "
                       "separated by a space (1.8), not '" +
                           m.endpoint.substr(0, 64) + "'");
    }
    slot = one;
    at = end + 1;
  }
  if ((m.paths & msg::kPhysShm) != 0 && unix_ep.empty()) {
    return makeError(Errc::invalid_argument, "shared memory is offered on a unix: endpoint only");
  }
  Offer& o = offers_[m.chan_id];
  o.paths = m.paths;
  o.unix_endpoint = unix_ep;
  o.tcp_endpoint = tcp_ep;
  log::info(kLogSource, "PHYS-OFFER",
            ch.name + ": " + ((m.paths & msg::kPhysShm) ? "shared memory " : "") +
                ((m.paths & msg::kPhysDirect) ? "direct " : "") + "at " + m.endpoint);
  return {};
}

Result<void> PhysicalPaths::request(Endpoint& e, const msg::PhysRequest& m, bool local) {
  auto found = channels_.existing(m.chan_id);
  if (!found) return found.error();
  Channel& ch = **found;
  if (std::find(e.subscribed.begin(), e.subscribed.end(), m.chan_id) == e.subscribed.end()) {
    return makeError(Errc::invalid_argument, "subscribe to " + ch.name + " before asking a path");
  }
  // The subscription passed the subscribe rule when it was made; rules may have changed since.
  if (!e.access->allows(Action::subscribe, ch.name)) {
    return accessDenied(e.user, Action::subscribe, ch.name);
  }
  auto it = offers_.find(m.chan_id);
  if (it == offers_.end() || ch.owner == nullptr) {
    return makeError(Errc::not_found, "the owner of " + ch.name + " offers no path");
  }
  Offer& o = it->second;
  // Shared memory and unix: endpoints need both ends on this machine (the subscriber on the
  // hub's Unix socket); a tcp: endpoint serves direct paths from anywhere.
  uint8_t path = 0;
  const std::string* endpoint = nullptr;
  if ((m.paths & o.paths & msg::kPhysShm) != 0 && local && !o.unix_endpoint.empty()) {
    path = msg::kPhysShm, endpoint = &o.unix_endpoint;
  } else if ((m.paths & o.paths & msg::kPhysDirect) != 0 && local && !o.unix_endpoint.empty()) {
    path = msg::kPhysDirect, endpoint = &o.unix_endpoint;
  } else if ((m.paths & o.paths & msg::kPhysDirect) != 0 && !o.tcp_endpoint.empty()) {
    path = msg::kPhysDirect, endpoint = &o.tcp_endpoint;
  } else {
    return makeError(Errc::unsupported, "no path to " + ch.name +
                                            " suits both ends (shared memory and unix: "
                                            "endpoints need both on this machine's socket)");
  }
  // A new grant replaces an old one (a subscriber asking again after its path broke).
  if (auto g = o.grants.find(e.id); g != o.grants.end()) revoke(o, ch, e.id, true);
  const std::string token = newToken();
  o.grants[e.id] = Grant{path, false};
  ch.owner->onPhysical(msg::EvPhysGrant{ch.id, e.id, e.user + "/" + e.client_name, path, token});
  e.onPhysical(msg::EvPhysPath{m.tag, ch.id, path, *endpoint, token});
  log::info(kLogSource, "PHYS-GRANT",
            ch.name + " to " + e.user + "/" + e.client_name + " (flow " + std::to_string(e.id) +
                "): " + (path == msg::kPhysShm ? "shared memory" : "direct"));
  return {};
}

Result<void> PhysicalPaths::state(Endpoint& e, const msg::PhysState& m) {
  auto it = offers_.find(m.chan_id);
  Channel* ch = channels_.find(m.chan_id);
  Grant* grant = nullptr;
  if (it != offers_.end() && ch != nullptr) {
    if (auto f = it->second.grants.find(e.id); f != it->second.grants.end()) grant = &f->second;
  }
  if (grant == nullptr) {
    // A path that broke because its owner or its grant went away: nothing is left to undo.
    if (m.active == 0) return {};
    return makeError(Errc::not_found, "no path to channel " + std::to_string(m.chan_id) +
                                          " was granted to this flow");
  }
  Grant& g = *grant;
  if (m.active == 0) {
    g.switching = 0;  // an answer still on its way is ignored
    if (!g.active) return {};
    g.active = false;
    channels_.setPhysical(e, m.chan_id, false);
    tellRelay(it->second, *ch);
    return {};
  }
  if (g.active || g.switching != 0) return {};
  if (ch->owner != nullptr && ch->owner->protocolMinor() >= 9) {
    // The owner picks the point: it answers before publishing anything else, so every message
    // before its answer is relayed and every one after it goes on the path.
    g.switching = nextId();
    ch->owner->onPhysical(msg::EvPhysSwitch{ch->id, e.id, g.switching});
    return {};
  }
  activate(it->second, *ch, e, g, std::nullopt);
  return {};
}

uint32_t PhysicalPaths::nextId() {
  if (++next_switch_ == 0) next_switch_ = 1;
  return next_switch_;
}

Result<void> PhysicalPaths::fallback(Endpoint& e, const msg::PhysFallback& m) {
  auto it = offers_.find(m.chan_id);
  Channel* ch = channels_.find(m.chan_id);
  if (it == offers_.end() || ch == nullptr) return {};  // the owner or the grant went: relayed
  auto g = it->second.grants.find(e.id);
  if (g == it->second.grants.end()) return {};
  if (!g->second.active || g->second.path != msg::kPhysDirect || ch->owner == nullptr ||
      ch->owner->protocolMinor() < 11) {
    return state(e, msg::PhysState{m.chan_id, 0});
  }
  // Off the path, not on the relay yet: the owner first sends what the path lost, in its
  // connection's order before what it publishes next, then relays again.
  g->second.active = false;
  g->second.resuming = nextId();
  g->second.resume_asked = monotonicNs();
  ch->owner->onPhysical(msg::EvPhysResume{ch->id, e.id, g->second.resuming, m.last});
  return {};
}

Result<void> PhysicalPaths::replay(Endpoint& e, const msg::PhysReplay& m) {
  auto owned = channels_.owned(e, m.chan_id, "replays paths of");
  if (!owned) return owned.error();
  Channel& ch = **owned;
  auto it = offers_.find(m.chan_id);
  if (it == offers_.end()) return {};
  Offer& o = it->second;
  auto g = o.grants.find(m.subscriber);
  Endpoint* subscriber = endpoints_.find(m.subscriber);
  const bool ours = g != o.grants.end() && subscriber != nullptr && g->second.resuming != 0 &&
                    g->second.resuming == m.resume_id;
  if (m.done == 0) {
    if (ours) subscriber->onData(ch, m.payload.bytes);
    return {};
  }
  // From the end on the owner publishes to the hub again, whatever became of the resume.
  o.relay_needed = true;
  if (ours) {
    g->second.resuming = 0;
    channels_.setPhysical(*subscriber, ch.id, false);
    subscriber->traffic.dropped += m.lost;
    ch.dropped += m.lost;
  }
  tellRelay(o, ch);
  return {};
}

Result<void> PhysicalPaths::switched(Endpoint& e, const msg::PhysSwitched& m) {
  auto owned = channels_.owned(e, m.chan_id, "switches paths of");
  if (!owned) return owned.error();
  auto it = offers_.find(m.chan_id);
  if (it == offers_.end()) return {};
  auto g = it->second.grants.find(m.subscriber);
  Endpoint* subscriber = endpoints_.find(m.subscriber);
  if (g == it->second.grants.end() || subscriber == nullptr || g->second.switching == 0 ||
      g->second.switching != m.switch_id) {
    return {};  // revoked, broken or asked again since
  }
  g->second.switching = 0;
  activate(it->second, **owned, *subscriber, g->second, m.seq);
  return {};
}

void PhysicalPaths::activate(Offer& o, Channel& ch, Endpoint& subscriber, Grant& g,
                             std::optional<uint64_t> last_relayed) {
  g.active = true;
  channels_.setPhysical(subscriber, ch.id, true);
  // The subscriber's marker: nothing of this channel is relayed to it after this event. With the
  // owner's message number it drops only the path's copies of what was relayed; without it (an
  // owner older than 1.9, or a subscriber that does not know the marker) it drops what came on
  // its path before the marker.
  if (last_relayed && subscriber.protocolMinor() >= 9) {
    subscriber.onPhysical(msg::EvPhysMarker{ch.id, *last_relayed});
  } else {
    subscriber.onPhysical(msg::EvPhysRelay{ch.id, 0});
  }
  tellRelay(o, ch);
}

Result<void> PhysicalPaths::count(Endpoint& e, const msg::PhysCount& m) {
  auto owned = channels_.owned(e, m.chan_id, "counts paths of");
  if (!owned) return owned.error();
  (*owned)->seq += m.messages;
  (*owned)->bytes += m.bytes;
  return {};
}

Result<void> PhysicalPaths::received(Endpoint& e, const msg::PhysReceived& m) {
  // A subscriber reports when its path breaks, which is also when the channel goes: a report for
  // a channel or a grant that went since is not an error.
  Channel* ch = channels_.find(m.chan_id);
  const auto o = offers_.find(m.chan_id);
  if (ch == nullptr || o == offers_.end() || o->second.grants.count(e.id) == 0) return {};
  e.traffic.messages_out += m.messages;
  e.traffic.bytes_out += m.bytes;
  e.traffic.path_messages += m.messages;
  e.traffic.path_bytes += m.bytes;
  e.traffic.dropped += m.missed;
  ch->dropped += m.missed;
  return {};
}

void PhysicalPaths::revoke(Offer& o, Channel& ch, uint32_t subscriber, bool tell_owner) {
  auto g = o.grants.find(subscriber);
  if (g == o.grants.end()) return;
  const bool was_active = g->second.active || g->second.resuming != 0;  // off the relay
  o.grants.erase(g);
  if (was_active) {
    if (Endpoint* s = endpoints_.find(subscriber)) channels_.setPhysical(*s, ch.id, false);
  }
  if (tell_owner && ch.owner != nullptr) ch.owner->onPhysical(msg::EvPhysRevoke{ch.id, subscriber});
  tellRelay(o, ch);
}

void PhysicalPaths::tellRelay(Offer& o, Channel& ch) {
  const bool needed =
      !ch.subscribers.empty() && std::any_of(ch.subscribers.begin(), ch.subscribers.end(),
                                             [](const Endpoint* s) { return s != nullptr; });
  if (needed == o.relay_needed || ch.owner == nullptr) return;
  o.relay_needed = needed;
  ch.owner->onPhysical(msg::EvPhysRelay{ch.id, static_cast<uint8_t>(needed ? 1 : 0)});
}

void PhysicalPaths::everySecond(Nanos now) {
  for (auto& [chan_id, o] : offers_) {
    Channel* ch = channels_.find(chan_id);
    if (ch == nullptr) continue;
    bool changed = false;
    for (auto& [sub, g] : o.grants) {
      if (g.resuming == 0 || now - g.resume_asked < kResumeTimeoutNs) continue;
      g.resuming = 0;
      changed = true;
      Endpoint* s = endpoints_.find(sub);
      if (s == nullptr) continue;
      channels_.setPhysical(*s, chan_id, false);
      log::warn(kLogSource, "PHYS-RESUME-LATE",
                ch->name + ": its owner did not replay what flow " + std::to_string(sub) +
                    " missed within 5 s; relayed without it");
    }
    if (changed) tellRelay(o, *ch);
  }
}

void PhysicalPaths::subscribersChanged(uint16_t chan_id) {
  auto it = offers_.find(chan_id);
  Channel* ch = channels_.find(chan_id);
  if (it != offers_.end() && ch != nullptr) tellRelay(it->second, *ch);
}

void PhysicalPaths::unsubscribed(Endpoint& e, uint16_t chan_id) {
  auto it = offers_.find(chan_id);
  Channel* ch = channels_.find(chan_id);
  if (it == offers_.end() || ch == nullptr) return;
  revoke(it->second, *ch, e.id, true);
}

void PhysicalPaths::dropEndpoint(Endpoint& e) {
  for (auto it = offers_.begin(); it != offers_.end();) {
    Channel* ch = channels_.find(it->first);
    if (ch == nullptr || ch->owner == &e) {
      it = offers_.erase(it);  // its owner left: its paths break on their own
      continue;
    }
    revoke(it->second, *ch, e.id, true);
    ++it;
  }
}

void PhysicalPaths::dropChannel(uint16_t chan_id) {
  auto it = offers_.find(chan_id);
  if (it == offers_.end()) return;
  Channel* ch = channels_.find(chan_id);
  if (ch != nullptr) {
    for (const auto& [sub, g] : std::map<uint32_t, Grant>(it->second.grants)) {
      revoke(it->second, *ch, sub, true);
    }
  }
  offers_.erase(chan_id);
}

size_t PhysicalPaths::grants(uint16_t chan_id) const {
  auto it = offers_.find(chan_id);
  return it == offers_.end() ? 0 : it->second.grants.size();
}

uint8_t PhysicalPaths::activePath(uint16_t chan_id, uint32_t subscriber) const {
  auto it = offers_.find(chan_id);
  if (it == offers_.end()) return 0;
  auto g = it->second.grants.find(subscriber);
  return g != it->second.grants.end() && g->second.active ? g->second.path : 0;
}

}  // namespace skr::flow
