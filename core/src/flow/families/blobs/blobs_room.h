// SPDX-License-Identifier: Apache-2.0
// The blobs room: the files of blob channels (blob_store.h, on its own thread; blob_path.h, the
// rules and confinement of paths), blob channels that outlive their owner's connection, the change
// events to subscribers, and the BLOB_* rows of the catalogue. A client may send up to
// kMaxInFlight blob requests (kMaxInFlightBytes of data) ahead of their answers; they are answered
// in order (Connection's pipeline keeps any other request behind them).
#pragma once

#include "families/blobs/blob_store.h"
#include "families/room.h"

#include <skrobot/runtime/flow/messages.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace skr::flow {

class Channel;
class Connection;
class HubLink;
class IoThread;

class BlobsRoom final : public Room {
 public:
  static constexpr uint32_t kMaxInFlight = 8;
  static constexpr uint64_t kMaxInFlightBytes = 8u << 20;

  explicit BlobsRoom(Hub& hub) : Room(hub) {}

  // The store; null without a data directory (blob requests are answered `unsupported`).
  [[nodiscard]] BlobStore* store() noexcept { return store_.get(); }
  // The I/O thread that serves connection `id` once it transfers files (io_relay.h); null when
  // the main loop serves them (no store, or server.blobs.io_threads 0).
  [[nodiscard]] std::shared_ptr<IoThread> ioThread(uint32_t id) const {
    return io_.empty() ? nullptr : io_[id % io_.size()];
  }

  // The blob channel `name` already there for `owner`: it becomes its owner again when it takes
  // events (a flow). Null when there is none.
  Channel* reattach(Endpoint& owner, const std::string& name, uint32_t tag);
  // Its owner left: the channel stays, owned by nobody connected.
  void detach(Endpoint& owner, Channel& ch);
  // A new blob channel: its directory is made on the store's thread; one that cannot be made
  // takes the channel with it (the owner `owner_id` hears why, with `tag`).
  void made(const Channel& ch, uint32_t owner_id, uint32_t tag,
            std::function<void(Result<void>)> stored);
  // The blob channel `id` for `e` to read (its subscribe rule) or write (its owner's user only):
  // not_found, permission_denied.
  Result<Channel*> channel(const Endpoint& e, uint16_t id, bool write);
  // Tells the subscribers of channel `id` (if it is still the channel `hash`) of a change.
  void changed(uint16_t id, uint64_t hash, const BlobEvent& event);

  // Its rows (catalogue.h, family blobs): handle(Connection&, msg::X&) for each.
  SKR_FLOW_ROOM_HANDLERS(blobs)

  // Room
  [[nodiscard]] Result<void> start() override;
  void stop() noexcept override;
  void endpointLeft(Endpoint& e) override;
  void channelRemoved(const Channel& ch) override;

 private:
  // A callback for the store that finds the connection again (if it is still there), answers
  // with `then` or the refusal, and lets the next requests in.
  template <class T>
  std::function<void(Result<T>)> later(Connection& c, Code code, uint64_t bytes,
                                       std::function<void(Connection&, Result<T>&)> then);
  // A request refused: the error to the caller and a tagged log line (BLOB-REFUSED, or BLOB-IO
  // when the disk failed), behind the blob answers still to come.
  void refuse(Connection& c, Code code, const Error& e);
  static void refuseNow(Connection& c, Code code, const Error& e);
  // The channel for a request, or refused (false).
  Channel* channelFor(Connection& c, Code code, uint16_t id, bool write);
  // Enough of this connection's requests in the hub: the next ones wait for answers.
  static void admitted(Connection& c);
  // The link that shows `ch`, a far hub's blob channel (null: a channel of this hub). A far one
  // whose link is gone is not in the table any more.
  [[nodiscard]] HubLink* farLink(const Channel& ch) const;
  void changeFile(Connection& c, Code code, uint16_t chan_id, const std::string& path);

  std::unique_ptr<BlobStore> store_;
  std::vector<std::shared_ptr<IoThread>> io_;
};

}  // namespace skr::flow
