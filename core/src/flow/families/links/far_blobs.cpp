// SPDX-License-Identifier: Apache-2.0
// A link's reads of the far hub's blob channels (see far_blobs.h).
#include "families/links/far_blobs.h"

#include <skrobot/satellite/sync_client.h>

namespace skr::flow {

FarBlobs::FarBlobs(std::string hub, sat::ConnectOptions options, Post post)
    : hub_(std::move(hub)),
      options_(std::move(options)),
      post_(std::move(post)),
      worker_("far-" + hub_, 0, WorkThread::AtStop::drop) {
  worker_.start();
}

FarBlobs::~FarBlobs() {
  worker_.stop();
  clients_.clear();  // the worker's, now that it stopped
}

Result<sat::SyncClient*> FarBlobs::client(uint32_t reader, bool* opened) {
  *opened = false;
  for (auto it = clients_.begin(); it != clients_.end(); ++it) {
    if (it->first != reader) continue;
    if (!it->second->isOpen()) {  // dropped: opened again below
      clients_.erase(it);
      break;
    }
    clients_.splice(clients_.begin(), clients_, it);
    return clients_.front().second.get();
  }
  auto made = sat::SyncClient::connect(options_);
  if (!made) return made.error();
  if (clients_.size() >= kMaxReaders) clients_.pop_back();
  clients_.emplace_front(reader, std::make_unique<sat::SyncClient>(std::move(made).value()));
  *opened = true;
  return clients_.front().second.get();
}

template <class T>
Result<T> FarBlobs::call(uint32_t reader, const std::function<Result<T>(sat::SyncClient&)>& fn) {
  for (;;) {
    bool opened = false;
    auto c = client(reader, &opened);
    if (!c) return farError(reader, c.error());
    auto r = fn(**c);
    if (!r && !opened && !(*c)->isOpen()) continue;  // broke while unused: once more, opened anew
    if (!r) return farError(reader, r.error());
    return r;
  }
}

Error FarBlobs::farError(uint32_t reader, const Error& e) {
  // A connection that failed is opened again at the reader's next request.
  std::erase_if(clients_,
                [reader](const auto& c) { return c.first == reader && !c.second->isOpen(); });
  Errc code = e.code;
  if (code == Errc::io_error || code == Errc::closed || code == Errc::timeout ||
      code == Errc::auth_failed) {
    code = Errc::io_error;  // the way there failed, not the request
  }
  return makeError(code, "hub " + hub_ + ": " + e.message);
}

void FarBlobs::list(uint32_t reader, uint16_t far_id, std::string dir,
                    std::function<void(Result<Variant>)> done) {
  worker_.post([this, reader, far_id, dir = std::move(dir), done = std::move(done)]() mutable {
    Result<Variant> r =
        call<Variant>(reader, [&](sat::SyncClient& c) { return c.blobListValue(far_id, dir); });
    post_([done = std::move(done), r = std::move(r)]() mutable { done(std::move(r)); });
  });
}

void FarBlobs::get(uint32_t reader, uint16_t far_id, std::string path, uint64_t version,
                   uint64_t offset, uint32_t max_bytes, size_t head_room,
                   std::function<void(Result<BlobStore::Read>)> done) {
  worker_.post([=, this, path = std::move(path), done = std::move(done)]() mutable {
    Result<BlobStore::Read> r =
        call<BlobStore::Read>(reader, [&](sat::SyncClient& c) -> Result<BlobStore::Read> {
          auto piece = c.blobRead(far_id, path, version, offset, max_bytes, head_room);
          if (!piece) return piece.error();
          BlobStore::Read read;
          read.version = piece->version;
          read.total_size = piece->total_size;
          read.data = std::move(piece->data);
          read.head = head_room;
          return read;
        });
    post_([done = std::move(done), r = std::move(r)]() mutable { done(std::move(r)); });
  });
}

void FarBlobs::forget(uint32_t reader) {
  worker_.post([this, reader] {
    std::erase_if(clients_, [reader](const auto& c) { return c.first == reader; });
  });
}

}  // namespace skr::flow
