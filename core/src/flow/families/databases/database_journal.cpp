// SPDX-License-Identifier: Apache-2.0
// The journal's writer thread (see database_journal.h).
#include "families/databases/database_journal.h"

#include "families/databases/database_log.h"

#include <skrobot/runtime/log.h>

#include <chrono>
#include <utility>

namespace skr::flow {
namespace {

constexpr std::string_view kLogSource = "flow.db";
constexpr auto kEverySec = std::chrono::seconds(1);

}  // namespace

const char* durabilityName(Durability d) noexcept {
  switch (d) {
    case Durability::always:
      return "always";
    case Durability::everysec:
      return "everysec";
    case Durability::no:
      return "no";
  }
  return "?";
}

Journal::Journal(std::shared_ptr<FileLayer> files, std::filesystem::path dir, Durability policy,
                 Post post, Durable durable)
    : files_(std::move(files)),
      dir_(std::move(dir)),
      policy_(policy),
      post_(std::move(post)),
      durable_(std::move(durable)) {
  thread_ = std::thread([this] { run(); });
}

Journal::~Journal() {
  stop();
}

std::filesystem::path Journal::path(const std::string& db, const char* suffix) const {
  return dir_ / (db + suffix);
}

uint64_t Journal::enqueue(Op op) {
  std::lock_guard lock(mutex_);
  op.seq = next_seq_++;
  const uint64_t seq = op.seq;
  // The writer sleeps only on an empty queue: one wake-up per batch, not per change.
  if (queue_.empty()) wake_.notify_one();
  queue_.push_back(std::move(op));
  return seq;
}

uint64_t Journal::append(const std::string& db, std::string records) {
  return enqueue(Op{Op::Kind::append, db, std::move(records), {}, 0, 0, {}});
}

uint64_t Journal::snapshot(const std::string& db, Variant::Map pairs, uint64_t version,
                           Snapshotted done) {
  return enqueue(Op{Op::Kind::snapshot, db, {}, std::move(pairs), version, 0, std::move(done)});
}

uint64_t Journal::drop(const std::string& db, std::string drop_record) {
  return enqueue(Op{Op::Kind::drop, db, std::move(drop_record), {}, 0, 0, {}});
}

void Journal::requestSync() {
  std::lock_guard lock(mutex_);
  sync_requested_ = true;
  wake_.notify_one();
}

void Journal::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    wake_.notify_one();
  }
  if (thread_.joinable()) thread_.join();
}

Result<FileLayer::File*> Journal::openLog(const std::string& db) {
  if (auto it = logs_.find(db); it != logs_.end()) return it->second.get();
  auto file = files_->open(path(db, ".log"), false);
  if (!file) return file.error();
  if ((*file)->size() == 0) {  // new: the header first, and its directory entry to be synced
    if (auto r = (*file)->append(dblog::kHeader); !r) return r.error();
    dir_unsynced_ = true;
  }
  return (logs_[db] = std::move(file).value()).get();
}

Result<void> Journal::carryOut(Op& op) {
  switch (op.kind) {
    case Op::Kind::append: {
      // Gathered, and written with one call per log and batch (writeGathered).
      if (auto log = openLog(op.db); !log) return log.error();
      gathered_[op.db].append(op.bytes);
      unsynced_.insert(op.db);
      return {};
    }
    case Op::Kind::snapshot: {
      if (auto r = writeGathered(); !r) return r;
      const std::string text = dblog::snapshotText(op.db, op.pairs, op.version);
      Result<void> r = replaceFile(*files_, dir_, op.db + ".json", text);
      if (r) {
        // The snapshot holds every record of the old log: start a new one.
        logs_.erase(op.db);
        unsynced_.erase(op.db);
        r = replaceFile(*files_, dir_, op.db + ".log", dblog::kHeader);
      }
      if (op.done) {
        Result<uint64_t> size = r ? Result<uint64_t>(uint64_t(text.size())) : r.error();
        post_([done = std::move(op.done), size = std::move(size)]() mutable { done(size); });
      }
      return r;
    }
    case Op::Kind::drop: {
      if (auto r = writeGathered(); !r) return r;
      // The drop record must be durable before the files go: a crash in between then leaves a
      // log that says "dropped", never a half-removed database that comes back.
      if (files_->exists(path(op.db, ".log"))) {
        auto log = openLog(op.db);
        if (!log) return log.error();
        if (auto r = (*log)->append(op.bytes); !r) return r;
        if (auto r = (*log)->sync(); !r) return r;
      }
      logs_.erase(op.db);
      unsynced_.erase(op.db);
      for (const char* suffix : {".json", ".log"}) {
        if (auto r = files_->remove(path(op.db, suffix)); !r && r.error().code != Errc::not_found) {
          return r;
        }
      }
      dir_unsynced_ = true;
      return {};
    }
  }
  return {};
}

Result<void> Journal::writeGathered() {
  Result<void> result;
  for (auto& [db, bytes] : gathered_) {
    if (bytes.empty()) continue;
    auto log = openLog(db);
    Result<void> r = log ? (*log)->append(bytes) : Result<void>(log.error());
    if (!r && result) result = r;
  }
  gathered_.clear();
  return result;
}

Result<void> Journal::syncAll() {
  Result<void> result;
  for (const std::string& db : unsynced_) {
    auto it = logs_.find(db);
    if (it == logs_.end()) continue;
    if (auto r = it->second->sync(); !r && result) result = r;
  }
  unsynced_.clear();
  if (dir_unsynced_) {
    if (auto r = files_->syncDir(dir_); !r && result) result = r;
    dir_unsynced_ = false;
  }
  return result;
}

void Journal::run() {
  if (auto r = files_->makeDir(dir_); !r) {
    log::error(kLogSource, "DB-LOG-FAILED", "the database directory: " + r.error().message);
  }
  auto last_sync = std::chrono::steady_clock::now();
  auto last_failure_log = last_sync - kEverySec;
  uint64_t failures_unlogged = 0;
  uint64_t written = 0;  // the last sequence number carried out
  for (;;) {
    std::vector<Op> batch;
    bool sync_requested = false;
    bool stopping = false;
    {
      std::unique_lock lock(mutex_);
      const auto ready = [this] { return !queue_.empty() || sync_requested_ || stopping_; };
      if (policy_ == Durability::everysec && (!unsynced_.empty() || dir_unsynced_)) {
        wake_.wait_until(lock, last_sync + kEverySec, ready);
      } else {
        wake_.wait(lock, ready);
      }
      batch.swap(queue_);
      sync_requested = std::exchange(sync_requested_, false);
      stopping = stopping_;
    }
    // One log line per batch at most, and one a second: a full disk fails every operation.
    Result<void> result;
    size_t failed = 0;
    const auto failure = [&](const Result<void>& r) {
      if (!r && failed++ == 0) result = r;
    };
    for (Op& op : batch) {
      failure(carryOut(op));
      written = op.seq;
    }
    failure(writeGathered());
    const auto now = std::chrono::steady_clock::now();
    const bool sync = sync_requested || stopping || policy_ == Durability::always ||
                      (policy_ == Durability::everysec && now - last_sync >= kEverySec);
    if (sync) failure(syncAll());
    if (failed > 0) {
      failures_unlogged += failed;
      if (now - last_failure_log >= kEverySec) {
        log::error(kLogSource, "DB-LOG-FAILED",
                   std::to_string(failures_unlogged) +
                       " journal operation(s) failed since the last report, the latest: " +
                       result.error().message +
                       "; the changes stay in memory, and each database's next snapshot "
                       "writes them");
        failures_unlogged = 0;
        last_failure_log = now;
      }
    }
    if (sync) {
      last_sync = now;
      post_([durable = durable_, written, result] { durable(written, result); });
    }
    if (stopping) {
      std::lock_guard lock(mutex_);
      if (queue_.empty()) return;
    }
  }
}

}  // namespace skr::flow
