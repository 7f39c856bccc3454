// SPDX-License-Identifier: Apache-2.0
// The files of the hub's blob channels: one tree per channel under <data_dir>/blobs/<channel>/
// (files/ the tree, uploads/ uploads under way, owner the owning user), with per-channel and
// per-user quotas. Every disk operation runs on the store's own thread, in the order asked; each
// answer is posted back to the loop thread. docs/blob-channels.md says what users see.
//
// Writes are atomic: an upload goes to uploads/<id>.part and, once its last byte arrived, is
// written, fsynced, renamed into place and its directory fsynced (that order, through BlobIo, so
// a test can check it). BLOB_MODIFY writes a copy the same way: a reader never sees a torn chunk.
#pragma once

#include <skrobot/runtime/flow/bytes.h>

#include "families/blobs/blob_path.h"
#include "work_thread.h"

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

// The system calls of a commit, behind an interface for the order test.
class BlobIo {
 public:
  virtual ~BlobIo() = default;
  [[nodiscard]] virtual Result<void> write(int fd, std::string_view data, uint64_t offset);
  [[nodiscard]] virtual Result<void> sync(int fd);
  [[nodiscard]] virtual Result<void> rename(int from_dir, const std::string& from, int to_dir,
                                            const std::string& to);
  [[nodiscard]] virtual Result<void> syncDir(int dir);
};

struct BlobQuota {
  uint64_t bytes = 0;  // 0: no limit
  uint64_t files = 0;
};

// A change that readers hear of (EV_BLOB_CHANGED).
struct BlobEvent {
  uint8_t change = 0;  // msg::BlobChange
  std::string path;
  uint64_t size = 0;
  uint64_t version = 0;
};

// The niceness of the threads that move files' bytes (the store's, the I/O threads'): above the
// hub's loop, so that under load the flows are scheduled first. Best effort.
inline constexpr int kBulkNice = 10;

class BlobStore {
 public:
  using Post = std::function<void(std::function<void()>)>;
  template <class T>
  using Done = std::function<void(Result<T>)>;

  // `post` runs a function on the loop thread. The largest chunk a read answers is `max_chunk`.
  BlobStore(std::filesystem::path root, BlobQuota per_channel, Post post,
            std::shared_ptr<BlobIo> io = std::make_shared<BlobIo>());
  ~BlobStore();
  BlobStore(const BlobStore&) = delete;
  BlobStore& operator=(const BlobStore&) = delete;

  struct Stored {
    std::string name, owner;
  };
  // At start, on the calling thread, before the worker runs: opens or creates the root and reads
  // the channels kept there (their usage and their unfinished uploads).
  [[nodiscard]] Result<std::vector<Stored>> open();

  struct Read {
    uint64_t version = 0, total_size = 0;
    std::string data;  // after `head` bytes left for the caller (get's head_room)
    size_t head = 0;
  };
  struct PutAt {
    uint64_t upload_id = 0, offset = 0;
  };
  struct Written {
    uint64_t received = 0, version = 0;
    std::optional<BlobEvent> event;  // set when a file changed
  };

  // Every call below runs on the worker; `done` runs on the loop thread.
  void create(const std::string& channel, const std::string& owner, Done<void> done);
  void drop(const std::string& channel, Done<void> done);
  void list(const std::string& channel, const std::string& dir, Done<Variant> done);
  // `reader` keeps one open version per connection: its next chunks come from that version.
  // The bytes are read into Read::data after `head_room` bytes, so that a frame header can be
  // written in front of them without copying them again.
  void get(uint32_t reader, const std::string& channel, const std::string& path, uint64_t version,
           uint64_t offset, uint32_t max_bytes, size_t head_room, Done<Read> done);
  // The whole current version of `path` (limit_exceeded when it is larger than `max_bytes`).
  void readAll(const std::string& channel, const std::string& path, uint64_t max_bytes,
               Done<Read> done);
  // An upload belongs to `writer` (a connection's endpoint id), the one that started it or last
  // resumed it (upload_id != 0): chunks from any other are refused, so that chunks still coming
  // from a connection that was cut never move the offset a resume was given.
  void put(uint32_t writer, const std::string& channel, BlobQuota user_quota,
           const std::string& path, uint64_t total_size, uint64_t upload_id, Done<PutAt> done);
  void chunk(uint32_t writer, const std::string& channel, uint64_t upload_id, uint64_t offset,
             SharedBytes data, Done<Written> done);
  void modify(const std::string& channel, BlobQuota user_quota, const std::string& path,
              uint64_t offset, SharedBytes data, Done<Written> done);
  void abort(const std::string& channel, uint64_t upload_id, Done<void> done);
  void mkdir(const std::string& channel, const std::string& path, Done<BlobEvent> done);
  void rmdir(const std::string& channel, const std::string& path, Done<BlobEvent> done);
  void remove(const std::string& channel, const std::string& path, Done<BlobEvent> done);
  // A reader went away: its open version is closed.
  void forget(uint32_t reader);
  // Runs `done` on the loop thread once everything asked before it ran.
  void barrier(std::function<void()> done);

  // The largest data a read answers, and a chunk may carry.
  static constexpr uint32_t kMaxChunk = 4u << 20;

 private:
  struct Channel;
  struct Upload;
  struct Reading;
  struct State;

  void enqueue(std::function<void()> job) { worker_.post(std::move(job)); }
  // Runs `op` on the parent directory of `path` in `channel`'s tree (made when `make`), then
  // makes the directory's change durable (worker thread).
  using PathOp = std::function<Result<BlobEvent>(Channel&, int parent, const std::string& name)>;
  void onPath(const std::string& channel, const std::string& path, bool make, PathOp op,
              Done<BlobEvent> done);
  // Opens the current version of `path` in `channel` for reading (worker thread).
  Result<Reading> openReading(const std::string& channel, const std::string& path);
  template <class T>
  void answer(Done<T> done, Result<T> r);

  std::filesystem::path root_;
  BlobQuota per_channel_;
  Post post_;
  std::shared_ptr<BlobIo> io_;
  std::unique_ptr<State> state_;  // the worker's only

  WorkThread worker_{"blob-store", kBulkNice, WorkThread::AtStop::finish};
};

}  // namespace skr::flow
