// SPDX-License-Identifier: Apache-2.0
// One named database mirrored to a JetStream key-value bucket, both ways (docs/fleet.md,
// "Databases"). Keys are mapped by encodeKey, values are JSON text. The bucket's order decides:
// at start the bucket's values replace the local ones, and local keys it lacks are put; after
// that every local change is put, every change in the bucket is applied, and when both change a
// key the later one in the bucket's sequence stays on both sides.
//
// The bucket's calls block on the server: they run on this mirror's own thread, which hands
// what the bucket says to the loop through `wake` and drain().
#pragma once

#include "bridge_config.h"
#include "nats_client.h"

#include <skrobot/plugin_watch.hpp>

#include <json/value.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace skr::nats_bridge {

class KvMirrorLink {
 public:
  using WakeFn = std::function<void(KvMirrorLink*)>;  // any thread: call drain() on the loop

  KvMirrorLink(plugin::Host& host, KvMirror config, WakeFn wake);
  ~KvMirrorLink();  // stop()
  KvMirrorLink(const KvMirrorLink&) = delete;
  KvMirrorLink& operator=(const KvMirrorLink&) = delete;

  // Loop thread: watches the database, starts the mirror's thread on `client`'s connection.
  void start(NatsClient& client);
  // Loop thread: joins the thread. Idempotent.
  void stop();
  // Loop thread: applies what the bucket said.
  void drain();
  [[nodiscard]] const std::string& db() const noexcept { return config_.db; }
  [[nodiscard]] Json::Value status() const;

 private:
  struct Change {  // one way or the other
    std::string key;
    std::optional<std::string> value;  // nullopt: removed
    bool initial_done = false;         // from the bucket: its current values have all come
    bool put_failed = false;           // from the thread: a local change did not reach it
  };
  void run(NatsClient& client);
  void local(const std::string& key, const std::optional<std::string>& value);
  void queuePut(const std::string& key, const std::optional<std::string>& value);

  plugin::Host& host_;
  KvMirror config_;
  WakeFn wake_;
  plugin::DatabaseWatch watch_;
  std::map<std::string, std::string> local_;  // the database's pairs, as the watch said
  std::map<std::string, int> in_flight_;      // local puts the bucket has not echoed yet
  std::map<std::string, bool> seen_;          // keys the bucket had at start
  bool initial_done_ = false;
  bool applying_ = false;  // a change from the bucket is being applied: not sent back
  uint64_t applied_ = 0, sent_ = 0, failed_ = 0;
  std::atomic<uint64_t> bad_keys_{0};  // the thread's count

  mutable std::mutex mutex_;  // below: the queues both ways, and the thread's state
  std::condition_variable cv_;
  std::deque<Change> to_bucket_;
  std::deque<Change> from_bucket_;
  std::string state_ = "waiting for the connection";
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace skr::nats_bridge
