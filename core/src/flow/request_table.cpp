// Service channels: requests routed to the owner, responses routed back to the requester only.
// Nothing is dropped silently: a request that cannot be queued, whose owner vanishes, or (for
// synchronous calls) that times out, fails with an error to the caller.
#include "server_impl.h"

#include <skrobot/core/log.h>

namespace skr::flow {

ErrorCode FlowServer::Impl::request(Endpoint& from, uint16_t chan_id, uint32_t tag, bool sync,
                                    uint32_t timeout_ms, const std::string& command,
                                    const Variant& value, std::string& why) {
  ErrorCode err = ErrorCode::ok;
  Channel* ch = existing(chan_id, err, why);
  if (ch == nullptr) return err;
  if (ch->kind != ChannelKind::service) {
    why = ch->name + " is not a service channel";
    return ErrorCode::invalid_argument;
  }
  if (ch->pending_requests >= opt.max_pending_requests) {
    why = ch->name + " has " + std::to_string(ch->pending_requests) +
          " unanswered requests, its limit";
    return ErrorCode::overflow;
  }
  if (ch->owner->congested()) {
    why = "the owner of " + ch->name + " is not reading its requests";
    return ErrorCode::overflow;
  }
  const uint64_t id = next_request++;
  PendingRequest p;
  p.chan_id = chan_id;
  p.requester = from.id;
  p.tag = tag;
  p.sync = sync;
  if (sync) {
    const Nanos timeout = timeout_ms == 0 ? 10 * kNsPerSec : timeout_ms * kNsPerMs;
    p.deadline = monotonicNs() + timeout;
  }
  requests.emplace(id, p);
  ++ch->pending_requests;
  ch->owner->onRequest(*ch, id, command, from.user, value);
  return ErrorCode::ok;
}

ErrorCode FlowServer::Impl::respond(Endpoint& from, uint16_t chan_id, uint64_t request,
                                    const Variant& value, std::string& why) {
  auto it = requests.find(request);
  if (it == requests.end()) {
    why = "no pending request " + std::to_string(request) + " (answered, timed out or cancelled)";
    return ErrorCode::not_found;
  }
  Channel* ch = channel(it->second.chan_id);
  if (ch == nullptr || ch->owner != &from || it->second.chan_id != chan_id) {
    why = "request " + std::to_string(request) + " was not made to a channel you own";
    return ErrorCode::permission_denied;
  }
  const PendingRequest p = it->second;
  requests.erase(it);
  --ch->pending_requests;
  if (auto e = endpoints.find(p.requester); e != endpoints.end()) {
    e->second->onResponse(p.chan_id, p.tag, p.sync, ErrorCode::ok, value);
  }
  return ErrorCode::ok;
}

void FlowServer::Impl::failRequests(uint16_t chan_id, ErrorCode error, const std::string& why) {
  std::vector<std::pair<uint64_t, PendingRequest>> failed;
  for (const auto& [id, p] : requests) {
    if (p.chan_id == chan_id) failed.emplace_back(id, p);
  }
  for (const auto& [id, p] : failed) {
    requests.erase(id);
    if (Channel* ch = channel(chan_id)) --ch->pending_requests;
    if (auto e = endpoints.find(p.requester); e != endpoints.end()) {
      e->second->onResponse(p.chan_id, p.tag, p.sync, error, Variant(why));
    }
  }
}

}  // namespace skr::flow
