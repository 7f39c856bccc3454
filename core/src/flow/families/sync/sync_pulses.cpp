// SPDX-License-Identifier: Apache-2.0
// The sync pulse (see sync_pulses.h).
#include "families/sync/sync_pulses.h"

#include <skrobot/runtime/log.h>

#include <algorithm>

namespace skr::flow {
namespace {

Result<Channel*> source(ChannelTable& channels, uint16_t chan_id) {
  auto found = channels.existing(chan_id);
  if (!found) return found.error();
  if ((*found)->kind != ChannelKind::sync) {
    return makeError(Errc::invalid_argument, (*found)->name + " is not a sync source");
  }
  return *found;
}

}  // namespace

Result<void> SyncPulses::follow(Endpoint& e, uint16_t chan_id, uint32_t every) {
  auto ch = source(channels_, chan_id);
  if (!ch) return ch.error();
  if (!e.access->allows(Action::subscribe, (*ch)->name)) {
    return accessDenied(e.user, Action::subscribe, (*ch)->name);
  }
  auto& targets = sources_[chan_id].targets;
  auto it = std::find_if(targets.begin(), targets.end(),
                         [&](const Target& t) { return t.endpoint == e.id; });
  const bool first = targets.empty();
  if (it == targets.end()) it = targets.insert(targets.end(), Target{.endpoint = e.id});
  it->every = std::max<uint32_t>(every, 1);
  it->skipped = 0;
  if (first && (*ch)->owner != nullptr) (*ch)->owner->onFollowers(**ch, true);
  return {};
}

Result<void> SyncPulses::unfollow(Endpoint& e, uint16_t chan_id) {
  auto ch = source(channels_, chan_id);
  if (!ch) return ch.error();
  if (auto s = sources_.find(chan_id); s != sources_.end()) {
    const size_t erased =
        std::erase_if(s->second.targets, [&](const Target& t) { return t.endpoint == e.id; });
    if (erased != 0 && s->second.targets.empty() && (*ch)->owner != nullptr) {
      (*ch)->owner->onFollowers(**ch, false);
    }
  }
  return {};
}

Result<void> SyncPulses::pulse(Endpoint& e, uint16_t chan_id, uint64_t source_time_ns) {
  auto owned = channels_.owned(e, chan_id, "pulses");
  if (!owned) return owned.error();
  const Channel& ch = **owned;
  if (ch.kind != ChannelKind::sync) {
    return makeError(Errc::invalid_argument, ch.name + " is not a sync source");
  }
  Source& s = sources_[chan_id];
  const uint64_t seq = ++s.seq;
  const uint64_t source_hash = ch.hash;
  // Decided first, delivered after: a module's handler runs during delivery and may follow,
  // unfollow, pulse or remove channels, which changes what the loop below walks.
  struct Due {
    uint32_t endpoint, dropped;
  };
  std::vector<Due> due;
  for (Target& t : s.targets) {
    if (++t.skipped < t.every) continue;
    t.skipped = 0;
    Endpoint* target = endpoints_.find(t.endpoint);
    if (target == nullptr) continue;
    if (t.waiting_for != 0) {
      ++t.dropped;
      ++target->traffic.sync_dropped;
      if (!t.lagging) {
        t.lagging = true;
        log::warn(kLogSource, "SYNC-TARGET-LAGGING",
                  target->describe() + " is still busy with pulse " +
                      std::to_string(t.waiting_for) + " of " + ch.name +
                      ": its tick takes longer than the pulse period; pulses are dropped for it");
      }
      continue;
    }
    if (t.lagging && t.dropped == 0) t.lagging = false;  // it kept up for a whole period
    due.push_back(Due{t.endpoint, t.dropped});
    t.dropped = 0;
    t.waiting_for = seq;
    ++target->traffic.sync_pulses;
  }
  for (const Due& d : due) {
    const Channel* now = channels_.find(chan_id);
    if (now == nullptr || now->hash != source_hash) break;  // removed by a handler
    if (Endpoint* target = endpoints_.find(d.endpoint)) {
      target->onSyncPulse(*now, seq, source_time_ns, d.dropped);
    }
  }
  return {};
}

void SyncPulses::done(Endpoint& e, uint16_t chan_id, uint64_t seq) {
  auto s = sources_.find(chan_id);
  if (s == sources_.end()) return;
  for (Target& t : s->second.targets) {
    if (t.endpoint == e.id && t.waiting_for == seq) t.waiting_for = 0;
  }
}

std::string SyncPulses::followedBy(uint32_t endpoint) const {
  std::string names;
  for (const auto& [id, s] : sources_) {
    for (const Target& t : s.targets) {
      if (t.endpoint != endpoint) continue;
      if (Channel* ch = channels_.find(id)) names += (names.empty() ? "" : ",") + ch->name;
    }
  }
  return names;
}

void SyncPulses::dropEndpoint(uint32_t endpoint) {
  std::vector<uint16_t> unfollowed;  // told after the loop: an owner may follow or unfollow
  for (auto& [id, s] : sources_) {
    const size_t erased =
        std::erase_if(s.targets, [&](const Target& t) { return t.endpoint == endpoint; });
    if (erased != 0 && s.targets.empty()) unfollowed.push_back(id);
  }
  for (uint16_t id : unfollowed) {
    const Channel* ch = channels_.find(id);
    if (ch != nullptr && ch->owner != nullptr && ch->owner->id != endpoint) {
      ch->owner->onFollowers(*ch, false);
    }
  }
}

void SyncPulses::dropSource(uint16_t chan_id) {
  sources_.erase(chan_id);
}

}  // namespace skr::flow
