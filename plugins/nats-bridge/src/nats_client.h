// SPDX-License-Identifier: Apache-2.0
// The bridge's NATS connection, on Debian's C client (libnats). Nothing here touches the hub:
// the client's threads and the bridge's own thread hand everything over through bounded queues.
//
// - Two connections, two lanes: `bulk` for streams (the client batches what it sends, up to a
//   millisecond) and `prompt` for services (requests, replies and their subscriptions: each
//   message goes out at once, natsOptions_SetSendAsap), so that a call does not wait for a
//   batch at each hop.
// - Outgoing work (publish, subscribe, unsubscribe, the connects themselves) goes through one
//   queue to the bridge's NATS thread, so that the hub's loop never blocks on the socket or on a
//   connect; past `queue_bytes` a publish is dropped and counted.
// - Incoming messages (the client's delivery threads) go to an inbox that the loop empties with
//   take(); `wake` is called when it turns non-empty. Past `queue_bytes` they are dropped and
//   counted.
// - No server at start: the connect is retried in the background (reconnect_min_ms doubling up
//   to reconnect_max_ms, for ever); a lost server likewise, and subscriptions are restored by
//   the client on reconnect.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace skr::nats_bridge {

struct ClientOptions {
  std::vector<std::string> servers;
  std::string name;  // the connection's name on the server
  std::string user, password, token, creds_file, nkey, nkey_seed_file;
  std::string tls_ca, tls_cert, tls_key;
  int64_t connect_timeout_ms = 2000;
  int64_t reconnect_min_ms = 100;
  int64_t reconnect_max_ms = 5000;
  size_t queue_bytes = 64u << 20;
};

// Headers the bridge reads and writes (docs/fleet.md).
inline constexpr const char* kCommandHeader = "Skr-Command";
inline constexpr const char* kErrorHeader = "Skr-Error";

enum class Lane { bulk = 0, prompt = 1 };

struct Incoming {
  uint64_t route = 0;  // the subscribe() call's route
  std::string subject, reply, data;
  std::string command, error;  // the headers above, if present
  bool no_responders = false;  // the server's answer to a request nobody took
};

struct ClientStats {
  std::string state;  // "connecting", "connected", "reconnecting", "closed"
  std::string server;
  uint64_t connects = 0, disconnects = 0;
  uint64_t out_msgs = 0, out_bytes = 0, in_msgs = 0, in_bytes = 0;
  uint64_t out_dropped = 0, in_dropped = 0;
  uint64_t out_queued_bytes = 0, in_queued_bytes = 0;
  std::string last_error;
};

class NatsClient {
 public:
  enum class Level { info, warn, error };
  using LogFn = std::function<void(Level, const char* tag, const std::string& text)>;
  // Any thread (the client's), under the inbox lock: post a drain to the loop. Never called
  // after stop() returned.
  using WakeFn = std::function<void()>;

  NatsClient(ClientOptions options, WakeFn wake, LogFn log);
  ~NatsClient();  // stop()
  NatsClient(const NatsClient&) = delete;
  NatsClient& operator=(const NatsClient&) = delete;

  // Starts the NATS thread, which connects (and keeps trying). False, with the reason, when the
  // options cannot be applied (a TLS or credentials file that cannot be read).
  bool start(std::string& error);
  // Joins the NATS thread, closes the connection, waits for the client's callbacks to finish.
  void stop();

  // Any thread. False when dropped (the queue is full, or stopped).
  bool publish(Lane lane, std::string subject, std::string data, std::string reply = {},
               std::string command = {}, std::string error = {});
  // Messages on `subject` (wildcards allowed) reach the inbox as `route` until unsubscribe().
  // `queue`: a queue group (one member of the group gets each message).
  void subscribe(Lane lane, uint64_t route, std::string subject, std::string queue = {});
  void unsubscribe(uint64_t route);
  // What arrived since the last call (loop thread).
  [[nodiscard]] std::deque<Incoming> take();
  // A subject prefix for this connection's replies, unique to it ("_INBOX.<random>").
  [[nodiscard]] const std::string& inbox() const noexcept { return inbox_; }
  [[nodiscard]] ClientStats stats() const;
  [[nodiscard]] bool connected() const noexcept { return connected_.load(); }
  // The prompt lane's natsConnection* (thread-safe in the client), for the key-value mirrors;
  // null until the NATS thread has made it, and after stop().
  [[nodiscard]] void* connection() const noexcept { return connections_[1].load(); }

  struct Shared;  // what the client's callbacks reach
  struct Route;   // one subscription's callback closure
  struct Link;    // one connection's callback closure

 private:
  struct Op {
    enum class Kind { publish, subscribe, unsubscribe } kind;
    Lane lane = Lane::bulk;
    uint64_t route = 0;
    std::string subject, reply, data, command, error;
  };
  void run();
  void apply(Op& op);
  bool connect();

  ClientOptions options_;
  LogFn log_;
  std::string inbox_;
  std::shared_ptr<Shared> shared_;
  std::atomic<bool> connected_{false};
  // The NATS thread's: the connections (natsConnection*, by Lane), subscriptions by route (a
  // natsSubscription* and its closure), and closures of ended ones (a late callback may read
  // them until stop()).
  std::atomic<void*> connections_[2] = {nullptr, nullptr};
  std::unique_ptr<Link> links_[2];
  std::map<uint64_t, std::pair<void*, std::unique_ptr<Route>>> subs_;
  std::vector<std::unique_ptr<Route>> retired_;

  mutable std::mutex mutex_;  // the outgoing queue
  std::condition_variable cv_;
  std::deque<Op> ops_;
  size_t ops_bytes_ = 0;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace skr::nats_bridge
