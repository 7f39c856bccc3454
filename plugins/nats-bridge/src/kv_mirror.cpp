// SPDX-License-Identifier: Apache-2.0
#include "kv_mirror.h"

#include "subject_map.h"

#include <skrobot/support/json.hpp>

#include <nats/nats.h>

#include <chrono>
#include <utility>

namespace skr::nats_bridge {

KvMirrorLink::KvMirrorLink(plugin::Host& host, KvMirror config, WakeFn wake)
    : host_(host), config_(std::move(config)), wake_(std::move(wake)) {}

KvMirrorLink::~KvMirrorLink() {
  stop();
}

void KvMirrorLink::start(NatsClient& client) {
  watch_ = plugin::DatabaseWatch(
      host_, config_.db, [this](const std::string& key, const std::optional<std::string>& value) {
        local(key, value);
      });
  thread_ = std::thread([this, &client] { run(client); });
}

void KvMirrorLink::stop() {
  watch_.reset();
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void KvMirrorLink::local(const std::string& key, const std::optional<std::string>& value) {
  if (key.empty() && !value) {  // cleared: every key goes
    for (const auto& [k, v] : std::exchange(local_, {})) {
      if (!applying_) queuePut(k, std::nullopt);
    }
    return;
  }
  if (value) {
    local_[key] = *value;
  } else {
    local_.erase(key);
  }
  // Changes made before the bucket's values came are sent once they have (drain()).
  if (!applying_ && initial_done_) queuePut(key, value);
}

void KvMirrorLink::queuePut(const std::string& key, const std::optional<std::string>& value) {
  ++in_flight_[key];
  ++sent_;
  {
    std::lock_guard lock(mutex_);
    to_bucket_.push_back(Change{key, value, false, false});
  }
  cv_.notify_all();
}

void KvMirrorLink::drain() {
  std::deque<Change> changes;
  {
    std::lock_guard lock(mutex_);
    changes.swap(from_bucket_);
  }
  for (Change& c : changes) {
    if (c.put_failed) {
      if (--in_flight_[c.key] <= 0) in_flight_.erase(c.key);
      ++failed_;
      continue;
    }
    if (c.initial_done) {
      if (initial_done_) continue;  // a watch restarted after a lost connection
      initial_done_ = true;
      // Local keys the bucket lacked go to it; the bucket's values already replaced the others.
      for (const auto& [k, v] : local_) {
        if (seen_.count(k) == 0) queuePut(k, v);
      }
      seen_.clear();
      continue;
    }
    if (!initial_done_) seen_[c.key] = true;
    if (auto it = in_flight_.find(c.key); it != in_flight_.end()) {
      // The bucket's answer to a put of ours (or a change that came before it): the last one in
      // the bucket's sequence is what stays, on both sides.
      if (--it->second <= 0) in_flight_.erase(it);
      continue;
    }
    applying_ = true;
    if (c.value) {
      if (plugin::dbSet(host_, config_.db, c.key, *c.value)) ++applied_;
    } else if (local_.count(c.key) != 0) {
      if (plugin::dbRemove(host_, config_.db, c.key)) ++applied_;
    }
    applying_ = false;
  }
}

Json::Value KvMirrorLink::status() const {
  Json::Value v(Json::objectValue);
  {
    std::lock_guard lock(mutex_);
    v["state"] = state_;
  }
  v["bucket"] = config_.bucket;
  v["applied"] = Json::UInt64(applied_);
  v["sent"] = Json::UInt64(sent_);
  v["failed"] = Json::UInt64(failed_);
  v["bad_keys"] = Json::UInt64(bad_keys_.load());
  return v;
}

namespace {
struct Bucket {
  Bucket() = default;
  Bucket(const Bucket&) = delete;
  Bucket& operator=(const Bucket&) = delete;
  jsCtx* js = nullptr;
  kvStore* kv = nullptr;
  kvWatcher* watcher = nullptr;
  void close() {
    if (watcher != nullptr) kvWatcher_Destroy(watcher);
    if (kv != nullptr) kvStore_Destroy(kv);
    if (js != nullptr) jsCtx_Destroy(js);
    watcher = nullptr;
    kv = nullptr;
    js = nullptr;
  }
  ~Bucket() { close(); }
};
}  // namespace

void KvMirrorLink::run(NatsClient& client) {
  Bucket b;
  auto setState = [&](std::string s) {
    std::lock_guard lock(mutex_);
    if (state_ != s) {
      host_.log.info("NATS-KV", config_.db, " <-> ", config_.bucket, ": ", s);
      state_ = std::move(s);
    }
  };
  auto toLoop = [&](Change c) {
    std::lock_guard lock(mutex_);
    const bool was_empty = from_bucket_.empty();
    from_bucket_.push_back(std::move(c));
    if (was_empty && !stopping_) wake_(this);
  };
  auto pause = [&](int ms) {
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, std::chrono::milliseconds(ms), [&] { return stopping_; });
  };
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) break;
    }
    auto* nc = static_cast<natsConnection*>(client.connection());
    if (nc == nullptr || !client.connected()) {
      pause(100);
      continue;
    }
    if (b.kv == nullptr) {
      natsStatus st = natsConnection_JetStream(&b.js, nc, nullptr);
      if (st == NATS_OK) st = js_KeyValue(&b.kv, b.js, config_.bucket.c_str());
      if (st == NATS_NOT_FOUND) {
        kvConfig cfg;
        kvConfig_Init(&cfg);
        cfg.Bucket = config_.bucket.c_str();
        cfg.History = 1;
        st = js_CreateKeyValue(&b.kv, b.js, &cfg);
      }
      if (st == NATS_OK) st = kvStore_WatchAll(&b.watcher, b.kv, nullptr);
      if (st != NATS_OK) {
        setState(std::string("no bucket yet: ") + natsStatus_GetText(st) +
                 " (is JetStream on? nats-server -js)");
        b.close();
        pause(1000);
        continue;
      }
      setState("mirroring");
    }
    // Local changes first, then what the bucket says.
    std::deque<Change> puts;
    {
      std::lock_guard lock(mutex_);
      puts.swap(to_bucket_);
    }
    for (Change& c : puts) {
      const std::string key = encodeKey(c.key);
      uint64_t rev = 0;
      const natsStatus st = c.value ? kvStore_PutString(&rev, b.kv, key.c_str(), c.value->c_str())
                                    : kvStore_Delete(b.kv, key.c_str());
      if (st != NATS_OK) {
        host_.log.warn("NATS-KV", config_.db, " key ", c.key, ": ", natsStatus_GetText(st));
        c.put_failed = true;
        toLoop(std::move(c));
      }
    }
    kvEntry* e = nullptr;
    const natsStatus st = kvWatcher_Next(&e, b.watcher, 50);
    if (st == NATS_TIMEOUT) continue;
    if (st != NATS_OK) {
      setState(std::string("watch lost: ") + natsStatus_GetText(st) + "; restarting it");
      b.close();
      pause(200);
      continue;
    }
    if (e == nullptr) {  // the bucket's current values have all come
      toLoop(Change{{}, std::nullopt, true, false});
      continue;
    }
    auto key = decodeKey(kvEntry_Key(e));
    if (!key || key->empty()) {
      ++bad_keys_;  // not a key this mirror writes: another client's, left alone
    } else if (kvEntry_Operation(e) == kvOp_Put) {
      const std::string data(static_cast<const char*>(kvEntry_Value(e)),
                             static_cast<size_t>(kvEntry_ValueLen(e)));
      toLoop(
          Change{*key, support::parseJson(data) ? data : support::jsonQuote(data), false, false});
    } else {
      toLoop(Change{*key, std::nullopt, false, false});
    }
    kvEntry_Destroy(e);
  }
}

}  // namespace skr::nats_bridge
