// SPDX-License-Identifier: Apache-2.0
// The request table: service requests waiting for their owner's answer. Routes a request to the
// owner and its response back to the requester only, and fails what cannot be answered: a full
// queue (overflow), an owner that goes away (owner_gone), a request past its deadline (timeout:
// every request has one, the caller's or the hub's default). Main loop thread only.
#pragma once

#include "endpoint.h"
#include "families/channels/channel_table.h"

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <functional>
#include <queue>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace skr::flow {

struct PendingRequest {
  uint16_t chan_id = 0;
  uint32_t requester = 0;  // endpoint id
  uint32_t tag = 0;
  bool sync = false;
  Nanos deadline = 0;
};

class RequestTable {
 public:
  // `max_per_channel`: unanswered requests a channel may hold; `default_timeout_ms`: the
  // deadline of a request that names none (ServerOptions).
  RequestTable(EndpointTable& endpoints, ChannelTable& channels, size_t max_per_channel,
               uint32_t default_timeout_ms)
      : endpoints_(endpoints),
        channels_(channels),
        max_per_channel_(max_per_channel),
        default_timeout_ms_(default_timeout_ms) {}

  // Queues a request from `from` to the owner of service channel `chan_id` and hands it over
  // (the owner may answer inside this call). It fails with `timeout` after timeout_ms (0: the
  // default). not_found, invalid_argument (not a service), overflow (queue full or owner
  // congested).
  [[nodiscard]] Result<void> request(Endpoint& from, uint16_t chan_id, uint32_t tag, bool sync,
                                     uint32_t timeout_ms, const std::string& command,
                                     const Variant& value);
  // The owner's answer to `request`, routed to the requester (if still there). not_found (no
  // such request pending), permission_denied (not made to a channel `from` owns). A hub link
  // passes on the far owner's failure as `error` (value: its message).
  [[nodiscard]] Result<void> respond(Endpoint& from, uint16_t chan_id, uint64_t request,
                                     const Variant& value, ErrorCode error = ErrorCode::ok);
  // What is left of `request`'s time, in ms (at least 1); 0 when it is not pending.
  [[nodiscard]] uint32_t remainingMs(uint64_t request, Nanos now) const;
  // Fails every request to `chan_id` with `error` (owner_gone when the channel goes).
  void failChannel(uint16_t chan_id, ErrorCode error, const std::string& why);
  // Fails the requests whose deadline passed with `timeout`, freeing their slots.
  void expire(Nanos now);
  [[nodiscard]] size_t pending() const noexcept { return requests_.size(); }
  // Forgets the requests `endpoint` made: nobody will read the answers.
  void dropRequester(uint32_t endpoint);

 private:
  using Requests = std::unordered_map<uint64_t, PendingRequest>;
  // Removes a request and takes it off its channel's and its requester's counts.
  PendingRequest take(Requests::iterator it);
  void answer(const PendingRequest& p, ErrorCode error, const Variant& value);

  EndpointTable& endpoints_;
  ChannelTable& channels_;
  size_t max_per_channel_;
  uint32_t default_timeout_ms_;
  Requests requests_;
  // (deadline, request), soonest first; entries of requests already gone are skipped.
  using Deadline = std::pair<Nanos, uint64_t>;
  std::priority_queue<Deadline, std::vector<Deadline>, std::greater<>> deadlines_;
  uint64_t next_request_ = 1;
};

}  // namespace skr::flow
