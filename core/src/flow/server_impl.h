// FlowServer::Impl: the hub's FlowNetwork server, wiring its parts. Main loop thread only.
//
//   endpoint.h          Endpoint (a satellite: Connection or LocalClient) and the EndpointTable
//   channel_table.h     channels, subscribers, and the router of published data
//   request_table.h     pending service requests, timeouts, owner-gone failures
//   sync_pulses.h       sync pulse sources and their targets
//   database_access.h   the PairDatabases and who may write them
//   connection.h        one socket satellite: framing, command handlers, output queue
//   server.cpp          transports, accept, output flushing, timeouts
//   server_wiring.cpp   what crosses the parts: endpoints arriving and leaving, channels
//                       created, removed or changed (databases, requests, events to all)
//   local_client.cpp    a module's in-process satellite
//
// docs/internals.md follows a published message through these files.
#pragma once

#include "blob_store.h"
#include "channel_table.h"
#include "database_access.h"
#include "endpoint.h"
#include "physical_paths.h"
#include "request_table.h"
#include "sync_pulses.h"

#include <skrobot/core/log.h>
#include <skrobot/core/loop.h>
#include <skrobot/flow/accounts.h>
#include <skrobot/flow/messages.h>
#include "login_throttle.h"

#include <skrobot/flow/messages.h>
#include <skrobot/flow/server.h>

#include <uv.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace skr::flow {

class Connection;
class HubLink;
class Replica;

struct FlowServer::Impl {
  Impl(Loop& loop, ServerOptions options);

  Loop& loop;
  ServerOptions opt;
  ServerStats stats;
  std::unique_ptr<Authenticator> auth;
  std::string unix_path;
  uint16_t tcp_port = 0;
  bool started = false;
  // Loaded by start() when opt.tls is set: every TCP connection is then a TLS session on it.
  std::optional<TlsContext> tls;

  uv_pipe_t* unix_listener = nullptr;
  uv_tcp_t* tcp_listener = nullptr;
  uv_prepare_t* flush_prepare = nullptr;
  uv_check_t* flush_check = nullptr;
  uv_timer_t* sweep_timer = nullptr;

  std::unordered_map<uint32_t, Connection*> connections;
  std::vector<Connection*> dirty;  // connections with output to flush
  LoginThrottle throttle;
  // Logins held back by the throttle: verified by sweep() once `at` has passed.
  struct DelayedLogin {
    uint32_t connection = 0;
    Nanos at = 0;
    msg::Login login;
  };
  std::vector<DelayedLogin> delayed_logins;

  // The parts. Declaration order is construction order: requests refer to the others.
  EndpointTable endpoints{opt.stats_clock};
  DatabaseAccess databases;
  ChannelTable channels{opt.stats_clock};
  RequestTable requests;
  SyncPulses syncs{endpoints, channels};
  PhysicalPaths physical{endpoints, channels};
  // The files of blob channels (blob_wiring.cpp); null without a data directory.
  std::unique_ptr<BlobStore> blobs;
  // When the last one-second samples of the rate windows were taken (sampleRates,
  // hub_stats.cpp): the spans of the hub's windows; and the wall clock at the newest.
  RateWindow<0> rate_ticks{opt.stats_clock(), {}};
  int64_t rates_until_ms = 0;

  // --- lifecycle, transports, output (server.cpp)
  Result<void> start();
  void stop() noexcept;
  Result<void> listenUnix();
  Result<void> listenTcp();
  void accept(uv_stream_t* listener, Transport transport);
  void markDirty(Connection* c);
  void flushDirty();
  void sweep();
  // Each endpoint's traffic counters into its flow database (once a second, from sweep).
  void writeFlowStats();
  // The sources `e` follows, into its flow database ("sync_following").
  void noteFollowed(const Endpoint& e);
  Nanos next_flow_stats = 0;

  // --- across the parts (server_wiring.cpp)
  // An endpoint logged in: its databases, its current database.
  void loggedIn(Endpoint& e);
  // An endpoint leaves: its subscriptions, channels, requests and flow database. Idempotent.
  void removeEndpoint(Endpoint& e);
  // A channel owned by `owner`, its database holding `props`; everyone is told (the owner with
  // `tag`), then waiting in-process subscriptions attach. A blob channel's store is created on
  // the store's thread: `stored` hears how that went.
  Result<Channel*> createChannel(Endpoint& owner, const std::string& short_name, ChannelKind kind,
                                 const std::string& mime, const Variant& props, uint32_t tag,
                                 std::function<void(Result<void>)> stored = {});
  // The same, named "<user>.<short_name>" for a `user` other than the owner's: a hub link's
  // remote channels ("<hub>/<user>.<name>").
  Result<Channel*> createChannelAs(Endpoint& owner, const std::string& user,
                                   const std::string& short_name, ChannelKind kind,
                                   const std::string& mime, const Variant& props, uint32_t tag,
                                   std::function<void(Result<void>)> stored = {});
  // Takes a channel out and tells everyone; a blob channel's files go too.
  void dropChannel(Channel& ch);
  // Only the owner removes a channel: its requests fail with owner_gone, everyone is told.
  Result<void> removeChannel(Endpoint& by, uint16_t id);
  // The owner changes a channel's properties; everyone is told (EV_CHAN_HEADER).
  Result<void> setProps(Endpoint& e, uint16_t id, const Variant& props);
  msg::ChannelInfo info(const Channel& ch) const;

  // --- blob channels (blob_wiring.cpp)
  // Opens the store and brings back the blob channels kept in it, owned by nobody connected.
  Result<void> startBlobs();
  // The blob channel `name` already there for `owner`: it becomes its owner again when it takes
  // events (a flow). Null when there is none.
  Channel* reattachBlob(Endpoint& owner, const std::string& name, uint32_t tag);
  // Its owner left: the channel stays, owned by nobody connected.
  void detachBlob(Endpoint& owner, Channel& ch);
  // The blob channel `id` for `e` to read (its subscribe rule) or write (its owner's user only):
  // not_found, permission_denied.
  Result<Channel*> blobChannel(const Endpoint& e, uint16_t id, bool write);
  // Tells the subscribers of channel `id` (if it is still the channel `hash`) of a change.
  void blobChanged(uint16_t id, uint64_t hash, const BlobEvent& event);
  // --- hub links (hub_links.cpp, docs/hub-links.md)
  std::string hub_name;                         // opt.hub_name, or the host's name
  std::vector<std::unique_ptr<HubLink>> links;  // the hubs this one links to
  void startLinks();
  // A connection said HUB_LINK_HELLO as hub `name`: invalid_argument (a bad name, or ours),
  // already_exists (a hub of that name is linked already), or it is marked as that link.
  Result<void> acceptHubLink(Connection& c, const std::string& name);
  // The link of this hub's config that took `c` as their shared connection, if any.
  HubLink* sharedLink(const Endpoint& c);
  // LINK_OFFER on a shared link's connection `c`: the linking hub's channel, owned here by `c`.
  // invalid_argument (not a shared link, a bad name or a route that loops or is too long),
  // already_exists (another route has it), permission_denied, limit_exceeded.
  Result<Channel*> linkOffer(Connection& c, const msg::LinkOffer& m);
  // Whether a linked hub's channel `name` may be shown here by a route of `hops` links: when no
  // channel has the name, or when the linked one that has it came by a longer route; that one is
  // dropped then (its subscribers follow the new one by name). docs/hub-links.md, "Routes".
  bool takeRoute(const std::string& name, size_t hops);
  // The link that reaches hub `hub`: the link to it, else one that shows its channels. Null when
  // none is up.
  HubLink* linkToward(std::string_view hub);
  // A read of database `db` for `e` (DB_READ, or a synchronous read of a linked hub's current
  // database): here, or on a linked hub ("<hub>/<name>", through linkToward(); that hub applies
  // its own rules to the link's account). `done` may be called later (never after the server).
  void readDatabase(const Endpoint& e, const std::string& db, msg::DbReadWhat what,
                    const std::string& key, std::function<void(Result<Variant>)> done);
  // --- replicas (replica.cpp)
  std::vector<std::unique_ptr<Replica>> replicas;
  // Mirrors `source` as "<owner_user>.<short_name>"; asked by `by` (its rules apply, and the
  // replica goes with it) or by the config (null). permission_denied, already_exists,
  // invalid_argument (not a streaming channel).
  Result<void> replicate(const std::string& owner_user, const std::string& source,
                         const std::string& short_name, const Endpoint* by);
  // not_found: no replica of that name asked by endpoint `by`.
  Result<void> stopReplica(const std::string& owner_user, const std::string& short_name,
                           uint32_t by);
  void dropReplicasOf(uint32_t requester);
  // --- administration (admin.cpp): ADMIN's commands, for administrators only
  Result<Variant> admin(Connection& by, const std::string& command, const Variant& args);
};

}  // namespace skr::flow
