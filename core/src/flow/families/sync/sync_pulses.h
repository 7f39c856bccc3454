// SPDX-License-Identifier: Apache-2.0
// The sync pulse (protocol 1.4): sources are channels of kind sync; targets follow one, every
// Nth pulse. A pulse goes to each target that finished its tick for the previous one (SYNC_DONE);
// for a target still busy it is dropped and counted, and the count rides on the next pulse it
// gets. Main loop thread only.
#pragma once

#include "endpoint.h"
#include "families/channels/channel_table.h"

#include <skrobot/runtime/result.h>

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace skr::flow {

class SyncPulses {
 public:
  SyncPulses(EndpointTable& endpoints, ChannelTable& channels)
      : endpoints_(endpoints), channels_(channels) {}

  // `e` follows source `chan_id`, every `every`th pulse (0, 1: each); again: a new `every`.
  // not_found, invalid_argument (not a source), permission_denied (its subscribe rule).
  [[nodiscard]] Result<void> follow(Endpoint& e, uint16_t chan_id, uint32_t every);
  // ok when `e` did not follow it.
  [[nodiscard]] Result<void> unfollow(Endpoint& e, uint16_t chan_id);
  // A pulse from the owner of `chan_id`, to its targets. not_found, permission_denied,
  // invalid_argument (not a source).
  [[nodiscard]] Result<void> pulse(Endpoint& e, uint16_t chan_id, uint64_t source_time_ns);
  // `e`'s tick for pulse `seq` of `chan_id` is done. A stale or unknown one is ignored.
  void done(Endpoint& e, uint16_t chan_id, uint64_t seq);
  // The sources `e` follows, by name ("" when none): its flow database shows them.
  [[nodiscard]] std::string followedBy(uint32_t endpoint) const;

  void dropEndpoint(uint32_t endpoint);
  void dropSource(uint16_t chan_id);

 private:
  struct Target {
    uint32_t endpoint = 0;
    uint32_t every = 1;
    uint32_t skipped = 0;      // pulses since its last due one (every)
    uint64_t waiting_for = 0;  // the pulse it has not finished (0: none)
    uint32_t dropped = 0;      // dropped since the last pulse it got
    bool lagging = false;      // in an episode of drops (logged once)
  };
  struct Source {
    uint64_t seq = 0;
    std::vector<Target> targets;
  };

  EndpointTable& endpoints_;
  ChannelTable& channels_;
  std::unordered_map<uint16_t, Source> sources_;
};

}  // namespace skr::flow
