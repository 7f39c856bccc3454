// SPDX-License-Identifier: Apache-2.0
// Physical mode (FlowProtocol 1.7, docs/physical-mode.md): the hub decides who may take a direct
// or shared-memory path to a channel and tells both ends; the bytes then bypass it. It keeps each
// channel's offer (the owner's endpoint and the kinds it serves) and each grant, moves a
// subscriber whose path works out of the relay (ChannelTable::setPhysical) and back when the path
// breaks, and revokes grants when a subscriber unsubscribes or leaves. Main loop thread only.
#pragma once

#include "endpoint.h"
#include "families/channels/channel_table.h"

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace skr::flow {

inline constexpr Nanos kResumeTimeoutNs = 5 * kNsPerSec;

class PhysicalPaths {
 public:
  PhysicalPaths(EndpointTable& endpoints, ChannelTable& channels)
      : endpoints_(endpoints), channels_(channels) {}

  // PHYS_OFFER from `e`. not_found, permission_denied (not the owner), invalid_argument (not
  // streaming, no paths known, an endpoint that is not unix:... or tcp:..., shm over tcp).
  [[nodiscard]] Result<void> offer(Endpoint& e, const msg::PhysOffer& m);
  // PHYS_REQUEST from `e`: a grant to the owner and the path to `e`. not_found (no channel, no
  // offer), invalid_argument (not subscribed), unsupported (no kind both sides take: shared
  // memory needs both on this machine's Unix socket).
  [[nodiscard]] Result<void> request(Endpoint& e, const msg::PhysRequest& m, bool local);
  // PHYS_STATE from `e`. not_found (no grant). A working path moves `e` out of the relay at
  // once for an owner older than 1.9; a newer owner is asked where (EV_PHYS_SWITCH) first.
  [[nodiscard]] Result<void> state(Endpoint& e, const msg::PhysState& m);
  // PHYS_SWITCHED from the owner: the subscriber leaves the relay here, and gets its marker.
  // permission_denied (not the owner); an answer to a switch given up since is ignored.
  [[nodiscard]] Result<void> switched(Endpoint& e, const msg::PhysSwitched& m);
  // PHYS_FALLBACK from a subscriber whose direct path broke (1.11): an owner of 1.11 is asked to
  // replay what came after `last` (EV_PHYS_RESUME), and the subscriber stays off the relay until
  // it has; otherwise as PHYS_STATE 0.
  [[nodiscard]] Result<void> fallback(Endpoint& e, const msg::PhysFallback& m);
  // PHYS_REPLAY from the owner: a kept message relayed to that subscriber alone, or the end,
  // from which it is relayed again. permission_denied (not the owner); an answer to a resume
  // given up since (the grant went, or was asked again) is ignored.
  [[nodiscard]] Result<void> replay(Endpoint& e, const msg::PhysReplay& m);
  // PHYS_COUNT from the owner. permission_denied.
  [[nodiscard]] Result<void> count(Endpoint& e, const msg::PhysCount& m);
  // PHYS_RECEIVED from a subscriber with a grant: added to its flow's traffic (and what it
  // skipped to the channel's drops). For a channel or a grant that went since the report left,
  // it is ignored.
  [[nodiscard]] Result<void> received(Endpoint& e, const msg::PhysReceived& m);

  // Once a second: a resume its owner has not ended within kResumeTimeoutNs is given up (the
  // subscriber is relayed).
  void everySecond(Nanos now);

  // Someone subscribed to `chan_id` or unsubscribed: the owner may have to relay again, or not.
  void subscribersChanged(uint16_t chan_id);
  // `e` is about to stop following `chan_id`: its grant is revoked.
  void unsubscribed(Endpoint& e, uint16_t chan_id);
  // `e` left: its grants and offers go.
  void dropEndpoint(Endpoint& e);
  void dropChannel(uint16_t chan_id);

  // Whether the owner of `chan_id` offers paths, and to whom they were granted (statistics).
  [[nodiscard]] size_t grants(uint16_t chan_id) const;
  // The working path `subscriber` takes to `chan_id`: msg::kPhysDirect or kPhysShm, 0 none.
  [[nodiscard]] uint8_t activePath(uint16_t chan_id, uint32_t subscriber) const;

 private:
  struct Grant {
    uint8_t path = 0;
    bool active = false;
    uint32_t switching = 0;  // the EV_PHYS_SWITCH the owner has not answered yet (0: none)
    uint32_t resuming = 0;   // the EV_PHYS_RESUME the owner has not ended yet (0: none)
    Nanos resume_asked = 0;
  };
  struct Offer {
    uint8_t paths = 0;
    std::string unix_endpoint, tcp_endpoint;  // "unix:<path>", "tcp:<host>:<port>"; one may be ""
    bool relay_needed = true;                 // as last told to the owner
    std::map<uint32_t, Grant> grants;         // by subscriber endpoint id
  };

  void revoke(Offer& o, Channel& ch, uint32_t subscriber, bool tell_owner);
  void tellRelay(Offer& o, Channel& ch);
  // `subscriber` leaves the relay; its marker names the owner's last message relayed, if known.
  void activate(Offer& o, Channel& ch, Endpoint& subscriber, Grant& g,
                std::optional<uint64_t> last_relayed);

  EndpointTable& endpoints_;
  ChannelTable& channels_;
  std::map<uint16_t, Offer> offers_;
  uint32_t next_switch_ = 0;  // EV_PHYS_SWITCH and EV_PHYS_RESUME ids
  [[nodiscard]] uint32_t nextId();
};

}  // namespace skr::flow
