// SPDX-License-Identifier: Apache-2.0
// The channels room: the channel table and its router (channel_table.h, the relay's hot path),
// channels made and removed with their databases and the events everyone gets, polling, and the
// CHAN_* / SUBSCRIBE / PUBLISH / POLL_* rows of the catalogue.
#pragma once

#include "families/channels/channel_table.h"
#include "families/room.h"

#include <skrobot/runtime/flow/messages.h>

#include <functional>
#include <string>

namespace skr::flow {

class Connection;

class ChannelsRoom final : public Room, public ChannelTable {
 public:
  explicit ChannelsRoom(Hub& hub);

  // A channel owned by `owner`, its database holding `props`; everyone is told (the owner with
  // `tag`), then waiting in-process subscriptions attach. A blob channel's store is made on the
  // store's thread: `stored` hears how that went.
  Result<Channel*> create(Endpoint& owner, const std::string& short_name, ChannelKind kind,
                          const std::string& mime, const Variant& props, uint32_t tag,
                          std::function<void(Result<void>)> stored = {});
  // The same, named "<user>.<short_name>" for a `user` other than the owner's: a hub link's
  // remote channels ("<hub>/<user>.<name>").
  Result<Channel*> createAs(Endpoint& owner, const std::string& user, const std::string& short_name,
                            ChannelKind kind, const std::string& mime, const Variant& props,
                            uint32_t tag, std::function<void(Result<void>)> stored = {});
  // Takes a channel out; every room hears of it (Room::channelRemoved), then everyone is told.
  void drop(Channel& ch);
  // Only the owner (or an administrator) removes a channel.
  Result<void> remove(Endpoint& by, uint16_t id);
  // The owner changes a channel's properties; everyone is told (EV_CHAN_HEADER).
  Result<void> setProps(Endpoint& e, uint16_t id, const Variant& props);
  [[nodiscard]] msg::ChannelInfo info(const Channel& ch) const;
  // Subscribes and unsubscribes, telling the physical room that the relay's subscribers changed.
  Result<void> subscribeAndTell(Endpoint& e, uint16_t id);
  Result<void> unsubscribeAndTell(Endpoint& e, uint16_t id);

  // Its rows (catalogue.h, family channels): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(channels)

  // Room
  void endpointLeft(Endpoint& e) override;
};

}  // namespace skr::flow
