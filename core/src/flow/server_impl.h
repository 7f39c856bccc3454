// Internals of the FlowServer, shared by its source files. Main loop thread only.
#pragma once

#include <skrobot/core/log.h>
#include <skrobot/core/loop.h>
#include <skrobot/flow/accounts.h>
#include <skrobot/flow/messages.h>
#include <skrobot/flow/pair_database.h>
#include <skrobot/flow/server.h>

#include <uv.h>

#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace skr::flow {

inline constexpr const char* kLogSource = "flow";

// A satellite as the channels see it: a socket connection or an in-process LocalClient.
class Endpoint {
 public:
  Endpoint() = default;
  virtual ~Endpoint() = default;
  Endpoint(const Endpoint&) = delete;
  Endpoint& operator=(const Endpoint&) = delete;
  Endpoint(Endpoint&&) = delete;
  Endpoint& operator=(Endpoint&&) = delete;

  uint32_t id = 0;
  std::string user;
  std::string client_name;
  std::string current_db;
  std::vector<uint16_t> owned;       // channels it owns
  std::vector<uint16_t> subscribed;  // channels it is subscribed to

  // True when it takes events (a flow, or a local client); sync connections do not.
  [[nodiscard]] virtual bool receivesEvents() const = 0;
  // Its output is backed up: service requests to it fail with `overflow` instead of queueing.
  [[nodiscard]] virtual bool congested() const = 0;
  [[nodiscard]] virtual std::string describe() const = 0;

  virtual void onData(const Channel& ch, std::string_view payload) = 0;
  virtual void onSubscribers(const Channel& ch, bool first) = 0;
  virtual void onRequest(const Channel& ch, uint64_t request, const std::string& command,
                         const std::string& requester, const Variant& value) = 0;
  // The answer to a request it made: `sync` ones were SERVICE_CALLs waiting for a reply.
  virtual void onResponse(uint16_t chan_id, uint32_t tag, bool sync, ErrorCode error,
                          const Variant& value) = 0;
  virtual void onChannelAdded(const Channel& ch, uint32_t tag) = 0;
  virtual void onChannelRemoved(const Channel& ch) = 0;
  virtual void onChannelHeader(const Channel& ch) = 0;
  virtual void onError(Code command, uint32_t tag, uint16_t chan_id, ErrorCode error,
                       const std::string& message) = 0;
  virtual void onDbChanged(const std::string& name) = 0;
};

class Channel {
 public:
  uint16_t id = 0;
  uint64_t hash = 0;
  ChannelKind kind = ChannelKind::streaming;
  std::string name;  // <user>.<short>
  std::string mime;
  Endpoint* owner = nullptr;
  // May hold nullptr tombstones while a publish is being dispatched (see Impl::dispatching).
  std::vector<Endpoint*> subscribers;
  size_t subscriber_count = 0;
  bool polled = false;  // keep the latest payload for POLL_FETCH
  std::string last;
  uint64_t seq = 0;
  size_t pending_requests = 0;
};

struct PendingRequest {
  uint16_t chan_id = 0;
  uint32_t requester = 0;  // endpoint id
  uint32_t tag = 0;
  bool sync = false;
  Nanos deadline = 0;  // sync calls only
};

class Connection;

struct FlowServer::Impl {
  Impl(Loop& loop, ServerOptions options);

  Loop& loop;
  ServerOptions opt;
  ServerStats stats;
  DatabaseStore dbs;
  std::unique_ptr<Authenticator> auth;
  std::string unix_path;
  uint16_t tcp_port = 0;
  bool started = false;

  uv_pipe_t* unix_listener = nullptr;
  uv_tcp_t* tcp_listener = nullptr;
  uv_prepare_t* flush_prepare = nullptr;
  uv_check_t* flush_check = nullptr;
  uv_timer_t* sweep_timer = nullptr;

  uint32_t next_endpoint_id = 1;
  std::unordered_map<uint32_t, Endpoint*> endpoints;
  std::unordered_map<uint32_t, Connection*> connections;
  std::vector<Connection*> dirty;  // connections with output to flush

  std::vector<std::unique_ptr<Channel>> channels;  // by id; [0] unused
  std::unordered_map<std::string, uint16_t> channel_by_name;
  uint16_t next_channel_hint = 1;
  size_t channel_count = 0;

  std::unordered_map<uint64_t, PendingRequest> requests;
  uint64_t next_request = 1;
  std::mt19937_64 rng;

  // Database name -> who may write it. Named databases (absent here) are writable by anyone.
  struct DbOwner {
    enum class Kind { user, flow, channel } kind;
    std::string user_name;
    uint32_t endpoint = 0;
  };
  std::unordered_map<std::string, DbOwner> db_owners;

  // Local subscriptions by name that wait for (or follow) their channel.
  std::multimap<std::string, uint32_t> local_wanted;

  int dispatching = 0;  // > 0 while publish iterates subscribers: removals leave tombstones
  std::vector<uint16_t> tombstoned;  // channels whose subscriber lists hold tombstones

  // --- lifecycle (server.cpp)
  Result<void> start();
  void stop() noexcept;
  Result<void> listenUnix();
  Result<void> listenTcp();
  void accept(uv_stream_t* listener, Transport transport);
  void markDirty(Connection* c);
  void flushDirty();
  void sweep();

  // --- endpoints
  uint32_t addEndpoint(Endpoint* e);
  void loggedIn(Endpoint& e);
  void removeEndpoint(Endpoint& e);  // channels, subscriptions, requests, flow database

  // --- channels (channels.cpp)
  Channel* channel(uint16_t id) noexcept;
  Channel* channelByName(const std::string& name) noexcept;
  // The channel `id`; else nullptr with `err` and `why` set.
  Channel* existing(uint16_t id, ErrorCode& err, std::string& why);
  // The channel `id` when `e` owns it ("only the owner <action> <name>" otherwise).
  Channel* owned(const Endpoint& e, uint16_t id, const char* action, ErrorCode& err,
                 std::string& why);
  Result<Channel*> createChannel(Endpoint& owner, const std::string& short_name, ChannelKind kind,
                                 const std::string& mime, const Variant& props, uint32_t tag);
  ErrorCode removeChannel(Endpoint& by, uint16_t id, std::string& why);
  ErrorCode subscribe(Endpoint& e, uint16_t id, std::string& why);
  ErrorCode unsubscribe(Endpoint& e, uint16_t id, std::string& why);
  ErrorCode publish(Endpoint& e, uint16_t id, std::string_view payload, std::string& why);
  ErrorCode setProps(Endpoint& e, uint16_t id, const Variant& props, std::string& why);
  msg::ChannelInfo info(const Channel& ch);
  void compact(Channel& ch);

  // --- services (services.cpp)
  ErrorCode request(Endpoint& from, uint16_t chan_id, uint32_t tag, bool sync, uint32_t timeout_ms,
                    const std::string& command, const Variant& value, std::string& why);
  ErrorCode respond(Endpoint& from, uint16_t chan_id, uint64_t request, const Variant& value,
                    std::string& why);
  void failRequests(uint16_t chan_id, ErrorCode error, const std::string& why);

  // --- databases (databases.cpp)
  PairDatabase* currentDb(Endpoint& e);
  bool canWrite(const Endpoint& e, const std::string& db) const;
  ErrorCode selectDb(Endpoint& e, const std::string& name, std::string& why);
  ErrorCode createDb(Endpoint& e, const std::string& name, std::string& why);
  ErrorCode saveDb(Endpoint& e, const std::string& name, std::string& why);
  ErrorCode removeDb(Endpoint& e, const std::string& name, std::string& why);
  ErrorCode setVar(Endpoint& e, const std::string& db, const std::string& key, const Variant& value,
                   std::string& why);
  ErrorCode delVar(Endpoint& e, const std::string& db, const std::string& key, std::string& why);
};

// Maps a core error to the protocol's.
ErrorCode toErrorCode(Errc code) noexcept;

}  // namespace skr::flow
