// SPDX-License-Identifier: Apache-2.0
// The request table (see request_table.h). Nothing is dropped silently: a request that cannot
// be queued, whose owner vanishes, or that times out, fails with an error to the caller.
#include "families/services/request_table.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace skr::flow {

Result<void> RequestTable::request(Endpoint& from, uint16_t chan_id, uint32_t tag, bool sync,
                                   uint32_t timeout_ms, const std::string& command,
                                   const Variant& value) {
  auto found = channels_.existing(chan_id);
  if (!found) return found.error();
  Channel* ch = *found;
  if (ch->kind != ChannelKind::service) {
    return makeError(Errc::invalid_argument, ch->name + " is not a service channel");
  }
  if (!from.access->allows(Action::call, ch->name)) {
    return accessDenied(from.user, Action::call, ch->name);
  }
  if (endpoints_.holdingsOf(from.user).pending_requests >= from.limits.pending_requests) {
    return limitReached(from.user, "pending requests", from.limits.pending_requests);
  }
  if (ch->pending_requests >= max_per_channel_) {
    return makeError(Errc::overflow, ch->name + " has " + std::to_string(ch->pending_requests) +
                                         " unanswered requests, its limit");
  }
  if (ch->owner->congested()) {
    return makeError(Errc::overflow, "the owner of " + ch->name + " is not reading its requests");
  }
  const uint64_t id = next_request_++;
  PendingRequest p;
  p.chan_id = chan_id;
  p.requester = from.id;
  p.tag = tag;
  p.sync = sync;
  p.deadline = monotonicNs() + Nanos(timeout_ms == 0 ? default_timeout_ms_ : timeout_ms) * kNsPerMs;
  requests_.emplace(id, p);
  deadlines_.emplace(p.deadline, id);
  ++ch->pending_requests;
  ++ch->seq;  // a service channel's messages, for statistics, are its requests
  ++from.pending_requests;
  ch->owner->onRequest(*ch, id, command, from.user, value);
  return {};
}

Result<void> RequestTable::respond(Endpoint& from, uint16_t chan_id, uint64_t request,
                                   const Variant& value, ErrorCode error) {
  auto it = requests_.find(request);
  if (it == requests_.end()) {
    return makeError(Errc::not_found, "no pending request " + std::to_string(request) +
                                          " (answered, timed out or cancelled)");
  }
  Channel* ch = channels_.find(it->second.chan_id);
  if (ch == nullptr || ch->owner != &from || it->second.chan_id != chan_id) {
    return makeError(Errc::permission_denied,
                     "request " + std::to_string(request) + " was not made to a channel you own");
  }
  const PendingRequest p = take(it);
  answer(p, error, value);
  return {};
}

uint32_t RequestTable::remainingMs(uint64_t request, Nanos now) const {
  auto it = requests_.find(request);
  if (it == requests_.end()) return 0;
  const Nanos left = it->second.deadline - now;
  return left <= kNsPerMs ? 1 : static_cast<uint32_t>(std::min<Nanos>(left / kNsPerMs, UINT32_MAX));
}

PendingRequest RequestTable::take(Requests::iterator it) {
  const PendingRequest p = it->second;
  requests_.erase(it);
  if (Channel* ch = channels_.find(p.chan_id)) --ch->pending_requests;
  if (Endpoint* e = endpoints_.find(p.requester); e != nullptr && e->pending_requests > 0) {
    --e->pending_requests;
  }
  return p;
}

void RequestTable::answer(const PendingRequest& p, ErrorCode error, const Variant& value) {
  if (Endpoint* e = endpoints_.find(p.requester)) {
    e->onResponse(p.chan_id, p.tag, p.sync, error, value);
  }
}

void RequestTable::failChannel(uint16_t chan_id, ErrorCode error, const std::string& why) {
  std::vector<std::pair<uint64_t, PendingRequest>> failed;
  for (const auto& [id, p] : requests_) {
    if (p.chan_id == chan_id) failed.emplace_back(id, p);
  }
  for (const auto& [id, p] : failed) {
    take(requests_.find(id));
    answer(p, error, Variant(why));
  }
}

void RequestTable::expire(Nanos now) {
  while (!deadlines_.empty() && deadlines_.top().first < now) {
    const uint64_t id = deadlines_.top().second;
    deadlines_.pop();
    auto it = requests_.find(id);
    if (it == requests_.end()) continue;  // answered or failed before
    const PendingRequest p = take(it);
    answer(p, ErrorCode::timeout, Variant("the service did not answer in time"));
  }
  // Answered requests leave their entries behind: drop them when they outnumber the live ones.
  if (deadlines_.size() > 2 * requests_.size() + 1024) {
    decltype(deadlines_) live;
    for (const auto& [id, p] : requests_) live.emplace(p.deadline, id);
    deadlines_.swap(live);
  }
}

void RequestTable::dropRequester(uint32_t endpoint) {
  for (auto it = requests_.begin(); it != requests_.end();) {
    if (it->second.requester == endpoint) {
      const auto next = std::next(it);
      take(it);
      it = next;
    } else {
      ++it;
    }
  }
}

}  // namespace skr::flow
