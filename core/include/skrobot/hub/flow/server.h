// SPDX-License-Identifier: Apache-2.0
// The FlowNetwork server: the hub's side of the FlowProtocol. It accepts satellites on a Unix
// socket and (optionally) TCP, logs them in, keeps the channels, routes data, service requests
// and database commands, and gives modules the same channels in process (LocalClient).
//
// Threading: everything here runs on the hub's main loop thread (the Loop passed in), except
// where a method says otherwise. Bad input never disturbs anyone but its sender: a frame that
// breaks the protocol closes that connection only, with a FLOW-PROTOCOL log line.
#pragma once

#include <skrobot/hub/flow/access.h>
#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/flow/serial.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/flow/udp.h>
#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skr::flow {

// A hub this one links to (docs/hub-links.md): its channels appear here as
// "<hub>/<user>.<name>", and data crosses only while someone here subscribes.
struct HubLinkOptions {
  std::string name;     // the far hub's hub_name, checked when the link opens
  std::string address;  // "local:/tmp/<app>", "tcp:host:port" or "tls:host:port"
  std::string user, password;
  TlsSettings tls;  // for tls: addresses: ca_file, and cert_file/key_file if the far hub asks
  uint32_t max_channels = 4096;  // remote channels this link may take of the hub's 32767 ids
  // An account of this hub's users file: what the far hub may do here over a shared connection
  // (its rules and limits; docs/hub-links.md, "One connection"). Empty: the default rules.
  std::string account;
};

// A replica the config asks for: `source` mirrored as "hub.<short_name>" for the hub's lifetime.
struct ReplicaOptions {
  std::string source, short_name;
};

// server.web (docs/config.md, docs/security.md): the hub's web port. Files (GET and HEAD) from
// `root` and `mounts`; with `flows`, FlowProtocol over WebSocket at /flow and page tokens at
// POST /skrobot/token. It speaks HTTPS and WSS only when ServerOptions::tls is set.
struct WebOptions {
  std::string address = "127.0.0.1";
  uint16_t port = 8080;  // 0: any free port (see FlowServer::webPort())
  // The page's files; empty: the installed web page (<prefix>/share/skrobot/web).
  std::filesystem::path root;
  // URL prefix ("/teleop", no trailing '/') -> the directory served under it.
  std::vector<std::pair<std::string, std::filesystem::path>> mounts;
  bool flows = false;  // FlowProtocol over WebSocket (GET /flow) and page tokens
  // Origins ("https://robot.local:8443") whose pages may open /flow and fetch tokens; empty: the
  // page's own (the scheme the port speaks + its Host). An absent Origin (Node.js, curl) passes.
  std::vector<std::string> origins;
  // Host names accepted besides IP literals, "localhost" and this machine's names (DNS rebinding).
  std::vector<std::string> hosts;
  std::string page_account = "web-page";  // what a page token logs in as
  uint32_t token_ttl_ms = 60000;          // how long a page token may be used to log in
  bool dev_account = false;  // ServerOptions::dev_account also on WebSocket from loopback
};

struct ServerOptions {
  std::string app_name = "Robot";
  // This hub's name in a linked network (hub links): unique there. Empty: the host name.
  std::string hub_name;
  std::vector<HubLinkOptions> links;
  // A far channel that went through more links than this is not shown (hub links).
  uint32_t link_hops = 8;
  std::vector<ReplicaOptions> replicas;
  bool unix_enabled = true;
  std::string unix_path;  // empty: /tmp/<app_name>
  bool tcp_enabled = false;
  std::string tcp_address = "127.0.0.1";
  uint16_t tcp_port = 9000;  // 0: any free port (see tcpPort())
  // Set: the TCP listener speaks TLS only (certificate and key required; ca_file set: clients
  // must present a certificate it signed). The files are loaded by start().
  std::optional<TlsSettings> tls;
  // Serial ports whose boards are satellites (a device may be a glob: each match is a port);
  // opened at start and whenever a listed device appears. docs/microcontrollers.md.
  std::vector<transport::SerialOptions> serial;
  // Set: boards' UDP sessions on this address and port (per-board keys, docs/microcontrollers.md).
  std::optional<transport::UdpOptions> udp;
  // Set: the web port (WebOptions above).
  std::optional<WebOptions> web;
  uint32_t max_frame_bytes = kDefaultMaxFrameBytes;
  // Streaming data queued for one subscriber beyond this is dropped, oldest first.
  size_t subscriber_queue_bytes = 8u << 20;
  // The most a subscription may ask for with SUBSCRIBE_QUEUE (1.13): a larger request is clamped
  // to it. A connection's queue is the larger of subscriber_queue_bytes and what its
  // subscriptions were granted.
  size_t subscriber_queue_max_bytes = 64u << 20;
  size_t max_connections = 1024;
  uint32_t login_timeout_ms = 5000;
  size_t max_pending_requests = 1024;   // unanswered service requests per channel
  uint32_t request_timeout_ms = 30000;  // a service request that names no timeout fails after it
  // What one user may hold at once unless its account says otherwise (flow/access.h).
  // blob_mib and blob_files 0: no limit unless the account sets one.
  UserLimits user_limits{64, 1024, 64, 1024, 0, 0};
  std::filesystem::path data_dir;  // persistent databases; empty: nothing is saved
  Durability durability = Durability::everysec;
  uint64_t compact_bytes = 4u << 20;  // a database log longer than this is compacted
  std::filesystem::path users_file;   // empty: <data_dir>/users.json
  // What one blob channel may hold (0: no limit); its files live in <data_dir>/blobs.
  uint64_t blob_channel_bytes = 0;
  uint64_t blob_channel_files = 0;
  // Threads that serve synchronous connections once they transfer files (Unix sockets, TCP, TLS;
  // docs/internals.md, "Threads"); 0: the main loop serves them.
  uint32_t blob_io_threads = 1;
  // A development account accepted on the Unix socket only (guest/password in the default
  // config). TCP never starts without real accounts in the users file.
  std::optional<std::pair<std::string, std::string>> dev_account;
  // The monotonic clock of the statistics' rate windows (when a channel or flow began, when
  // sampleRates() closes a second). Tests drive time with their own; the hub keeps the default.
  Nanos (*stats_clock)() = &monotonicNs;
};

// Counters a test or an operator can read (FlowServer::stats()).
struct ServerStats {
  uint64_t connections_accepted = 0;
  uint64_t connections_open = 0;
  uint64_t protocol_errors = 0;  // connections closed for breaking the protocol
  uint64_t logins_failed = 0;
  uint64_t frames_in = 0;
  // A connection's frames left for a later turn, its budget spent (fair turns: kFramesPerTurn).
  uint64_t turns_yielded = 0;
  // Synchronous connections handed to an I/O thread at their first blob request (blob_io_threads).
  uint64_t connections_moved = 0;
  uint64_t data_frames_out = 0;
  uint64_t data_frames_dropped = 0;  // slow subscribers
  uint64_t tls_refused = 0;          // TLS handshakes failed, or a plain and TLS peer mismatched
  uint64_t db_watches = 0;           // DB_WATCH watches in force (1.14)
};

class Channel;
class LocalClient;
namespace http {
class MessageTransport;  // runtime/internal/http_head.h
}
struct HubSnapshot;

// Events a LocalClient (an in-process satellite) receives. Data arrives as a view of the
// publisher's buffer, valid only during the call: no copy is made for in-process subscribers.
struct LocalHandlers {
  std::function<void(uint16_t chan_id, std::string_view payload)> on_data;
  std::function<void(uint16_t chan_id, bool first)> on_subscribers;  // first arrived / last gone
  // A request to a service channel this client owns; answer with LocalClient::respond().
  std::function<void(uint16_t chan_id, uint64_t request, const std::string& command,
                     const std::string& requester, const Variant& value)>
      on_request;
  // The answer to LocalClient::request(). error != ok: the request failed (owner_gone, overflow,
  // ...: the Errc of the wire error a satellite gets, see toErrc) and value holds the message.
  std::function<void(uint16_t chan_id, uint32_t tag, Errc error, const Variant& value)> on_response;
  // A channel was added (added = true) or removed, with its kind and mime type.
  std::function<void(uint16_t chan_id, const std::string& name, ChannelKind kind,
                     const std::string& mime, bool added)>
      on_channel;
  // A pulse of a source it follows (LocalClient::follow); answer with LocalClient::syncDone.
  std::function<void(uint16_t chan_id, uint64_t seq, uint64_t source_time_ns, uint32_t dropped)>
      on_sync_pulse;
  // Physical mode (docs/physical-mode.md), to the owner of a channel it offered paths for
  // (LocalClient::offerPaths): a subscriber's grant, its revocation, whether the relay is needed.
  std::function<void(const msg::EvPhysGrant&)> on_phys_grant;
  std::function<void(const msg::EvPhysRevoke&)> on_phys_revoke;
  std::function<void(const msg::EvPhysRelay&)> on_phys_relay;
  // A subscriber's path works: answer with LocalClient::switchedPaths before publishing again.
  std::function<void(const msg::EvPhysSwitch&)> on_phys_switch;
  // A subscriber's direct path broke: answer with LocalClient::replayPaths (what was kept, then
  // the end) before publishing again.
  std::function<void(const msg::EvPhysResume&)> on_phys_resume;
};

class FlowServer {
 public:
  // Does not listen yet; start() does. `loop` must outlive the server.
  FlowServer(Loop& loop, ServerOptions options);
  ~FlowServer();  // closes every connection and listener
  FlowServer(const FlowServer&) = delete;
  FlowServer& operator=(const FlowServer&) = delete;
  FlowServer(FlowServer&&) = delete;
  FlowServer& operator=(FlowServer&&) = delete;

  // Loads the databases, accounts and TLS files, then listens. Fails (and listens on nothing)
  // when a transport cannot be opened, a TLS file is bad, or TCP is enabled without real
  // accounts. Sets SIGPIPE to be
  // ignored for the process: a peer that closes mid-write must not kill the hub.
  [[nodiscard]] Result<void> start();
  // Saves dirty persistent databases, closes all connections and listeners. Idempotent.
  void stop() noexcept;

  [[nodiscard]] const ServerOptions& options() const noexcept;
  [[nodiscard]] std::string unixPath() const;
  [[nodiscard]] uint16_t tcpPort() const noexcept;  // the bound port (useful with port 0)
  [[nodiscard]] uint16_t udpPort() const noexcept;  // server.udp's bound port; 0 without one
  [[nodiscard]] uint16_t webPort() const noexcept;  // server.web's bound port; 0 without one
  // A module's WebSocket endpoint on the web port (plugin ABI 1.8): an upgrade of GET `path`
  // offering `subprotocol` is handed to `accepted` as a transport of whole messages of at most
  // `max_message_bytes`. Errc::unsupported without server.web; WebPort::serve's errors.
  [[nodiscard]] Result<void> serveWebSocket(
      const std::string& path, std::string subprotocol, uint64_t max_message_bytes,
      std::function<void(std::unique_ptr<http::MessageTransport>)> accepted);
  void unserveWebSocket(const std::string& path) noexcept;
  [[nodiscard]] const ServerStats& stats() const noexcept;
  [[nodiscard]] size_t channelCount() const noexcept;
  [[nodiscard]] const std::string& hubName() const noexcept;  // options().hub_name or the host's
  // Every channel's and flow's counters now, with their rates over the last second and the
  // last ten as of the last sampleRates() (flow/hub_stats.h).
  [[nodiscard]] HubSnapshot snapshot() const;
  // Closes a second of every channel's and flow's rate windows, at options().stats_clock() now:
  // HubStats calls it on each one-second tick. A walk over the channels and flows copying a few
  // counters each; the relay itself only counts.
  void sampleRates();

  // An in-process satellite (a module) logged in as `user`, with its own flow database, acting
  // under `access` (null: the default rules). Handlers run on the main loop thread. The client
  // must be destroyed before the server.
  [[nodiscard]] std::unique_ptr<LocalClient> attachLocal(
      const std::string& user, const std::string& name, LocalHandlers handlers,
      std::shared_ptr<const AccessRules> access = nullptr);
  // The role, rules and limits of an account of the users file; null when there is none.
  [[nodiscard]] std::shared_ptr<const AccessRules> accountAccess(const std::string& account) const;

  // --- what the hub's supervisor of satellites asks (docs/robot.md; supervised.cpp)
  // A password for one run of the supervised satellite `name`, accepted for `account` (empty:
  // the satellite's own name, with the default rules) until removed
  // (Authenticator::addSatellitePassword). Removed with the user it logs in as.
  [[nodiscard]] Result<std::string> addSatellitePassword(const std::string& account,
                                                         const std::string& name);
  void removeSatellitePassword(const std::string& user, const std::string& password);
  // Called on the loop thread each time a satellite logs in with its run's password.
  void onSatelliteLogin(std::function<void(const std::string& name, uint32_t connection)> fn);
  [[nodiscard]] bool hasChannel(const std::string& name) const;
  // The connections logged in with satellite `name`'s passwords now, with their channels.
  struct SatelliteFlow {
    uint32_t id = 0;
    std::string user, client;
    std::vector<std::string> channels;
  };
  [[nodiscard]] std::vector<SatelliteFlow> flowsOfSatellite(const std::string& name) const;
  // An ADMIN command answered by another part of the hub (administrators only, as every ADMIN
  // command; logged FLOW-ADMIN): `answer` once, now or later, on the loop thread (the
  // connection waits; an answer for a connection gone is dropped). Remove it before that part
  // goes.
  using AdminAnswer = std::function<void(Result<Variant>)>;
  using AdminCommand = std::function<void(const Variant& args, AdminAnswer answer)>;
  void addAdminCommand(const std::string& name, AdminCommand run);
  void removeAdminCommand(const std::string& name) noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// An in-process satellite. Main loop thread only. Its channels are removed when it is
// destroyed, and everyone is told, exactly as for a satellite that disconnects.
class LocalClient {
 public:
  ~LocalClient();
  LocalClient(const LocalClient&) = delete;
  LocalClient& operator=(const LocalClient&) = delete;
  LocalClient(LocalClient&&) = delete;
  LocalClient& operator=(LocalClient&&) = delete;

  // Creates "<user>.<short_name>"; props become the channel's database.
  [[nodiscard]] Result<uint16_t> createChannel(const std::string& short_name, ChannelKind kind,
                                               const std::string& mime, const Variant& props);
  [[nodiscard]] Result<void> removeChannel(uint16_t chan_id);
  // The channel's current id, if it exists now.
  [[nodiscard]] std::optional<uint16_t> findChannel(const std::string& name) const;
  // The messages channel `chan_id` retains (plugin ABI 1.9), oldest first; none when there is
  // no such channel. For a second subscriber inside one client (a module's Subscriptions).
  [[nodiscard]] std::vector<std::shared_ptr<const std::string>> retained(uint16_t chan_id) const;
  struct ChannelInfo {
    uint16_t id = 0;
    std::string name;
    ChannelKind kind = ChannelKind::streaming;
    std::string mime;
  };
  // Every channel there is now (local and linked hubs'), by id.
  [[nodiscard]] std::vector<ChannelInfo> channels() const;
  // Publishes on an owned streaming channel: in-process subscribers get a view of `payload`
  // (no copy), satellites a frame each.
  [[nodiscard]] Result<void> publish(uint16_t chan_id, std::string_view payload);
  // A message of `chan_id` delivered here that its receiver could not take (a module's thread
  // too far behind): counted as a subscriber's queue drop is, for the flow and the channel
  // (hub.stats `dropped`).
  void dropped(uint16_t chan_id);
  // publish(), keeping `payload` as the message retained under `key`, and forgetting one (or
  // all: nullopt): ChannelTable::publishRetained, clearRetained (plugin ABI 1.9).
  [[nodiscard]] Result<void> publishRetained(uint16_t chan_id, std::string_view key,
                                             std::string_view payload);
  [[nodiscard]] Result<void> clearRetained(uint16_t chan_id, std::optional<std::string_view> key);
  // Physical mode: offers paths to an owned streaming channel (PHYS_OFFER, as a satellite's
  // library sends it), and counts what its paths delivered while nobody was relayed (PHYS_COUNT).
  [[nodiscard]] Result<void> offerPaths(const msg::PhysOffer& m);
  [[nodiscard]] Result<void> countPaths(const msg::PhysCount& m);
  [[nodiscard]] Result<void> switchedPaths(const msg::PhysSwitched& m);
  [[nodiscard]] Result<void> replayPaths(const msg::PhysReplay& m);
  // A pulse of an owned sync source (docs/sync-pulse.md), stamped with the monotonic clock.
  [[nodiscard]] Result<void> pulse(uint16_t chan_id);
  // Follows a sync source by name, every `every`th pulse; like subscribe() it waits for a source
  // that does not exist yet and follows it again when it is re-created. Again: a new `every`.
  [[nodiscard]] Result<void> follow(const std::string& name, uint32_t every);
  void unfollow(const std::string& name);
  // Its tick for pulse `seq` of source `chan_id` is over: the next pulse may come.
  void syncDone(uint16_t chan_id, uint64_t seq);
  // Subscribes by name; if the channel does not exist yet the subscription waits for it, and it
  // follows the channel when it is removed and created again.
  [[nodiscard]] Result<void> subscribe(const std::string& name);
  void unsubscribe(const std::string& name);
  // A service request; the answer comes through on_response with `tag`.
  [[nodiscard]] Result<void> request(uint16_t chan_id, uint32_t tag, const std::string& command,
                                     const Variant& value);
  [[nodiscard]] Result<void> respond(uint16_t chan_id, uint64_t request, const Variant& value);
  // Databases: reads anywhere, writes where this client may write (see docs/pair-databases.md).
  [[nodiscard]] std::optional<Variant> getVariable(const std::string& db, const std::string& key);
  [[nodiscard]] Result<void> setVariable(const std::string& db, const std::string& key,
                                         const Variant& value);
  // Every pair of a database (a map), if it exists.
  [[nodiscard]] std::optional<Variant> pairsOf(const std::string& db) const;
  [[nodiscard]] Result<void> removeVariable(const std::string& db, const std::string& key);
  // Watches a database this client may read (it need not exist yet): `fn` is told each change,
  // as DatabaseStore::watch says. The id for unwatchDatabase(); the watch ends with the client.
  [[nodiscard]] Result<uint64_t> watchDatabase(const std::string& db, DatabaseStore::ChangeFn fn);
  void unwatchDatabase(uint64_t id) noexcept;
  // A barrier: `done` runs on the loop thread once every database change made so far is on
  // disk, whatever the durability policy (docs/pair-databases.md). It may run after this client
  // is gone: hold nothing of it there.
  void syncDatabases(std::function<void(Result<void>)> done);

  // Blob channels (docs/blob-channels.md), as a satellite's synchronous requests: checked now
  // (an error, and `done` is never called), run on the store's thread, answered through `done`
  // on the loop thread, possibly after this client is gone: hold nothing of it there. A
  // subscription (subscribe()) to a blob channel gets each change as on_data with a JSON object
  // {"change": "written"|"removed"|"dir_added"|"dir_removed", "path", "size", "version"}.
  enum class BlobOp { mkdir, rmdir, remove };
  struct BlobFile {
    uint64_t version = 0;
    std::string data;
  };
  [[nodiscard]] Result<void> blobList(uint16_t chan_id, const std::string& dir,
                                      std::function<void(Result<Variant>)> done);
  // The whole current version of a file of at most `max_bytes`.
  [[nodiscard]] Result<void> blobGet(uint16_t chan_id, const std::string& path, uint64_t max_bytes,
                                     std::function<void(Result<BlobFile>)> done);
  // Replaces (or creates) a file of an owned blob channel with `data`, atomically: the version.
  [[nodiscard]] Result<void> blobPut(uint16_t chan_id, const std::string& path, std::string data,
                                     std::function<void(Result<uint64_t>)> done);
  [[nodiscard]] Result<void> blobDo(uint16_t chan_id, BlobOp op, const std::string& path,
                                    std::function<void(Result<void>)> done);
  [[nodiscard]] const std::string& user() const noexcept;
  [[nodiscard]] uint32_t id() const noexcept;

  struct Impl;
  explicit LocalClient(std::unique_ptr<Impl> impl);

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace skr::flow
