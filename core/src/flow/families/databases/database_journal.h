// SPDX-License-Identifier: Apache-2.0
// The journal: one writer thread that appends the persistent databases' changes to their logs,
// fsyncs them by the durability policy, and compacts a log into its snapshot, so that the loop
// thread never waits for the disk (docs/pair-databases.md, "Durability").
//
// Operations are queued by the loop thread and carried out in order. Each gets a sequence
// number; after every fsync the journal tells the loop thread (through `post`) the last number
// that is now durable. A batch of operations queued while the previous batch was being written
// shares one fsync per file, so concurrent writers under `always` share their fsyncs.
#pragma once

#include "families/databases/file_layer.h"

#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/runtime/flow/variant.h>

#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace skr::flow {

class Journal {
 public:
  using Post = std::function<void(std::function<void()>)>;
  // On the loop thread: everything up to `seq` was written and fsynced, or failed with `r`.
  using Durable = std::function<void(uint64_t seq, const Result<void>& r)>;
  // On the loop thread: a snapshot was written (its size in bytes), or why not.
  using Snapshotted = std::function<void(Result<uint64_t>)>;

  // The logs and snapshots live in `dir`. Starts the writer thread.
  Journal(std::shared_ptr<FileLayer> files, std::filesystem::path dir, Durability policy, Post post,
          Durable durable);
  ~Journal();  // stop()
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  // Loop thread. Each returns its sequence number.
  // Appends encoded records (database_log.h) to <db>.log; empty `records` creates the log only.
  uint64_t append(const std::string& db, std::string records);
  // Writes <db>.json from `pairs` at `version`, then starts <db>.log afresh.
  uint64_t snapshot(const std::string& db, Variant::Map pairs, uint64_t version, Snapshotted done);
  // Appends `drop_record`, fsyncs it, then removes <db>.json and <db>.log.
  uint64_t drop(const std::string& db, std::string drop_record);
  // Asks for an fsync of everything queued so far, whatever the policy (a barrier).
  void requestSync();
  // Writes and fsyncs everything queued, then joins the thread. Idempotent; blocks.
  void stop();

  [[nodiscard]] Durability policy() const noexcept { return policy_; }

 private:
  struct Op {
    enum class Kind { append, snapshot, drop } kind;
    std::string db;
    std::string bytes;
    Variant::Map pairs;
    uint64_t version = 0;
    uint64_t seq = 0;
    Snapshotted done;
  };

  uint64_t enqueue(Op op);
  void run();
  Result<void> carryOut(Op& op);
  Result<FileLayer::File*> openLog(const std::string& db);
  // Writes the appends gathered in this batch, one call per log.
  Result<void> writeGathered();
  Result<void> syncAll();
  std::filesystem::path path(const std::string& db, const char* suffix) const;

  const std::shared_ptr<FileLayer> files_;
  const std::filesystem::path dir_;
  const Durability policy_;
  const Post post_;
  const Durable durable_;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<Op> queue_;
  uint64_t next_seq_ = 1;
  bool sync_requested_ = false;
  bool stopping_ = false;

  // Writer thread only.
  std::map<std::string, std::unique_ptr<FileLayer::File>> logs_;
  std::map<std::string, std::string> gathered_;  // appends of this batch, per database
  std::set<std::string> unsynced_;
  bool dir_unsynced_ = false;

  std::thread thread_;
};

}  // namespace skr::flow
