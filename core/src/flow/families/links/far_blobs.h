// SPDX-License-Identifier: Apache-2.0
// FarBlobs: the reads of a far hub's blob channels that a link passes on (docs/hub-links.md,
// "Blob channels"). Each BLOB_LIST and BLOB_GET asked here goes to the far hub on a synchronous
// connection of the link's account, one per reader here (so each reader keeps the version it
// reads, as it would on that hub), opened when first needed. The client calls block, so they run
// on a thread of their own, in the order asked; each answer is posted back to the loop. A chunk
// is passed on as it comes: no file is held whole.
#pragma once

#include "families/blobs/blob_store.h"
#include "work_thread.h"

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/result.h>
#include <skrobot/satellite/address.h>

#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <string>
#include <utility>

namespace skr::sat {
class SyncClient;
}

namespace skr::flow {

class FarBlobs {
 public:
  using Post = std::function<void(std::function<void()>)>;
  // Connections to the far hub `hub` with `options`; `post` runs a function on the loop thread.
  FarBlobs(std::string hub, sat::ConnectOptions options, Post post);
  // Waits for the request under way (at most the options' timeout); the rest are dropped.
  ~FarBlobs();
  FarBlobs(const FarBlobs&) = delete;
  FarBlobs& operator=(const FarBlobs&) = delete;

  // Loop thread. `reader`: the connection here that asks; `far_id`: the channel's id there.
  void list(uint32_t reader, uint16_t far_id, std::string dir,
            std::function<void(Result<Variant>)> done);
  void get(uint32_t reader, uint16_t far_id, std::string path, uint64_t version, uint64_t offset,
           uint32_t max_bytes, size_t head_room, std::function<void(Result<BlobStore::Read>)> done);
  // The reader left: its connection to the far hub closes.
  void forget(uint32_t reader);

  // Readers with a connection open to the far hub at once; the one unused longest closes first.
  static constexpr size_t kMaxReaders = 16;

 private:
  // The reader's connection, opened if needed (`*opened` says so) (worker thread).
  Result<sat::SyncClient*> client(uint32_t reader, bool* opened);
  // `fn` on the reader's connection; one that broke since its last use (the far hub restarted)
  // is opened again once (worker thread).
  template <class T>
  Result<T> call(uint32_t reader, const std::function<Result<T>(sat::SyncClient&)>& fn);
  // An error of the far hub, or of the way there, as this hub's readers see it (worker thread).
  Error farError(uint32_t reader, const Error& e);

  std::string hub_;
  sat::ConnectOptions options_;
  Post post_;
  // The worker's only: connections by reader, the most recently used first.
  std::list<std::pair<uint32_t, std::unique_ptr<sat::SyncClient>>> clients_;

  WorkThread worker_;  // last: stops (dropping what did not start) before the rest goes
};

}  // namespace skr::flow
