// SPDX-License-Identifier: Apache-2.0
// The links room: this hub's links to other hubs (hub_link.h: a satellite of the far hub on this
// hub's loop, and an endpoint here that owns the far hub's channels as "<hub>/<user>.<name>"),
// the far hubs that link in (HUB_LINK_HELLO, one shared connection for two hubs that list each
// other), routes between several hubs, replicas (a channel mirrored under another name), and the
// HUB_LINK_HELLO, LINK_OFFER, REPLICATE_* and TIME_PROBE rows of the catalogue
// (docs/hub-links.md).
#pragma once

#include "families/links/hub_link.h"
#include "families/links/replica.h"
#include "families/room.h"

#include <skrobot/runtime/flow/messages.h>

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

class Connection;

class LinksRoom final : public Room {
 public:
  explicit LinksRoom(Hub& hub) : Room(hub) {}

  // The links of the config, dialled once the server listens, and the config's replicas.
  void connect();
  [[nodiscard]] const std::vector<std::unique_ptr<HubLink>>& all() const noexcept { return links_; }
  // The link that reaches hub `hub`: the link to it, else one that shows its channels. Null when
  // none is up.
  [[nodiscard]] HubLink* toward(std::string_view hub) const;
  // The link that `e` is (the owner of the far channels it shows), if it is one.
  [[nodiscard]] HubLink* link(const Endpoint& e) const;
  // The link of this hub's config that took `c` as their shared connection, if any.
  [[nodiscard]] HubLink* shared(const Endpoint& c) const;
  // Whether a linked hub's channel `name` may be shown here by a route of `hops` links: when no
  // channel has the name, or when the linked one that has it came by a longer route; that one is
  // dropped then (its subscribers follow the new one by name). docs/hub-links.md, "Routes".
  bool takeRoute(const std::string& name, size_t hops);
  // A read of a linked hub's database "<hub>/<name>" through the link toward it; not_found when
  // none is up.
  void readDatabase(const std::string& db, msg::DbReadWhat what, const std::string& key,
                    std::function<void(Result<Variant>)> done);
  // A connection became a flow: a shared link's asks the linking hub for its channels.
  void flowOpened(Connection& c);
  // Asks the linking hub on the shared connection `c` to offer its channels (EV_LINK_WANTED).
  void askOffers(Connection& c);

  // Mirrors `source` as "<owner_user>.<short_name>"; asked by `by` (its rules apply, and the
  // replica goes with it) or by the config (null). permission_denied, already_exists,
  // invalid_argument (not a streaming channel).
  Result<void> replicate(const std::string& owner_user, const std::string& source,
                         const std::string& short_name, const Endpoint* by);
  // not_found: no replica of that name asked by endpoint `by`.
  Result<void> stopReplica(const std::string& owner_user, const std::string& short_name,
                           uint32_t by);

  // Its rows (catalogue.h, family links): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(links)

  // Room
  void stop() noexcept override;
  void endpointLeft(Endpoint& e) override;
  void everySecond(Nanos now) override;

 private:
  // A connection said HUB_LINK_HELLO as hub `name`: invalid_argument (a bad name, or ours),
  // already_exists (a hub of that name is linked already), or it is marked as that link.
  Result<void> accept(Connection& c, const std::string& name);
  // LINK_OFFER on a shared link's connection `c`: the linking hub's channel, owned here by `c`.
  // invalid_argument (not a shared link, a bad name or a route that loops or is too long),
  // already_exists (another route has it), permission_denied, limit_exceeded.
  Result<Channel*> offered(Connection& c, const msg::LinkOffer& m);

  std::vector<std::unique_ptr<HubLink>> links_;  // the hubs this one links to
  std::vector<std::unique_ptr<Replica>> replicas_;
};

}  // namespace skr::flow
