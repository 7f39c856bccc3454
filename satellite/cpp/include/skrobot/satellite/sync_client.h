// SPDX-License-Identifier: Apache-2.0
// A synchronous connection to a hub: one request, one reply, in the calling thread.
//
// This is the short-lived connection of the FlowProtocol for look-ups that block (database
// reads, blocking service calls, channel lists), kept apart from the satellite's flow so that the
// flow never blocks. Every method blocks the calling thread until the reply arrives or
// ConnectOptions::timeout_ms passes. Not thread-safe: use one SyncClient from one thread at a time.
//
// Errors: a refusal by the hub keeps its FlowProtocol error in lastError() and maps onto the Errc
// of the same name by toErrc() (not_found, already_exists, owner_gone, timeout, ...); the
// connection stays usable. A lost or broken connection gives Errc::closed or Errc::protocol_error
// and closes.
#pragma once

#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/result.h>
#include <skrobot/satellite/address.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {
class InBuffer;  // the runtime's (internal)
}  // namespace skr::flow

namespace skr::sat {

using ChannelInfo = flow::msg::ChannelInfo;
using LoginInfo = flow::msg::LoginOk;

// The Errc that a hub's FlowProtocol error maps onto: the one mapping of
// skrobot/runtime/flow/protocol.h, shared with the hub's modules (same name, one for one).
using flow::toErrc;

// Progress of a transfer: bytes done, bytes in all.
using BlobProgress = std::function<void(uint64_t done, uint64_t total)>;

class SyncClient {
 public:
  SyncClient() = default;
  ~SyncClient();
  SyncClient(const SyncClient&) = delete;
  SyncClient& operator=(const SyncClient&) = delete;
  SyncClient(SyncClient&& o) noexcept;
  SyncClient& operator=(SyncClient&& o) noexcept;

  // Connects and logs in. Errors:
  //   Errc::io_error           nobody listens: "no hub at local:/tmp/Robot: is skrobot running?"
  //   Errc::auth_failed        the login was refused (wrong user name or password)
  //   Errc::version_mismatch   the hub speaks another protocol major
  //   Errc::protocol_error     a reply that breaks the protocol
  //   Errc::timeout            no answer within options.timeout_ms
  [[nodiscard]] static Result<SyncClient> connect(const ConnectOptions& options);

  [[nodiscard]] bool isOpen() const noexcept { return fd_ >= 0; }
  [[nodiscard]] const LoginInfo& login() const noexcept { return login_; }
  // The hub's error code for the last failed request (ok after a success).
  [[nodiscard]] flow::ErrorCode lastError() const noexcept { return last_error_; }
  void close() noexcept;

  // Databases. The current database starts as the user's own.
  [[nodiscard]] Result<void> selectDatabase(const std::string& name);
  [[nodiscard]] Result<void> createDatabase(const std::string& name);
  [[nodiscard]] Result<void> saveDatabase(const std::string& name = {});  // empty: current
  [[nodiscard]] Result<void> removeDatabase(const std::string& name);
  // Returns once every database change the hub made before this request is on disk, whatever
  // its durability policy (DB_SYNC, protocol 1.2; unsupported from an older hub).
  [[nodiscard]] Result<void> syncDatabases();
  [[nodiscard]] Result<std::vector<std::string>> databases();
  // Variables of the current database.
  [[nodiscard]] Result<flow::Variant> get(const std::string& key);
  [[nodiscard]] Result<void> set(const std::string& key, const flow::Variant& value);
  [[nodiscard]] Result<void> del(const std::string& key);
  [[nodiscard]] Result<flow::Variant::Map> getAll();
  [[nodiscard]] Result<std::vector<std::string>> keys();

  // Channels of the hub now.
  [[nodiscard]] Result<std::vector<ChannelInfo>> channels();
  [[nodiscard]] Result<ChannelInfo> channel(const std::string& name);

  // A blocking service call (SERVICE_CALL): waits for the owner's answer for up to timeout_ms
  // (Errc::timeout), or fails when the owner goes away (Errc::owner_gone).
  [[nodiscard]] Result<flow::Variant> call(uint16_t chan_id, const std::string& command,
                                           const flow::Variant& value, uint32_t timeout_ms = 5000);
  // The same by channel name (one CHAN_INFO first).
  [[nodiscard]] Result<flow::Variant> call(const std::string& service, const std::string& command,
                                           const flow::Variant& value, uint32_t timeout_ms = 5000);

  // Polling a streaming channel instead of subscribing: once registered, the hub keeps the
  // channel's latest payload (while any client polls it) and pollFetch() reads it: seq is the
  // channel's sequence number of that payload, 0 while nothing was published since the first
  // registration. pollDeregister (protocol 1.4; Errc::unsupported from an older hub) lets the hub
  // stop keeping it; Errc::not_found when this client was not registered.
  struct Polled {
    uint64_t seq = 0;
    std::string payload;
  };
  [[nodiscard]] Result<void> pollRegister(uint16_t chan_id);
  [[nodiscard]] Result<Polled> pollFetch(uint16_t chan_id);
  [[nodiscard]] Result<void> pollDeregister(uint16_t chan_id);

  // Round trip with the hub.
  [[nodiscard]] Result<void> ping();

  // Blob channels (protocol 1.3; Errc::unsupported from an older hub): docs/blob-channels.md.
  // Reads work for every user the hub's rules allow; writes for the channel's owner only
  // (permission_denied). Transfers run in chunks with a few requests ahead of their replies.
  struct BlobEntry {
    std::string name;
    bool dir = false;
    uint64_t size = 0;
    int64_t mtime_ns = 0;
    uint64_t version = 0;
  };
  // The caller's blob channel <user>.<short_name>, created unless it exists.
  [[nodiscard]] Result<ChannelInfo> createBlobChannel(const std::string& short_name);
  [[nodiscard]] Result<std::vector<BlobEntry>> blobList(uint16_t chan_id,
                                                        const std::string& dir = {});
  // The same as the hub's answer: a list of maps (name, dir, size, mtime_ns, version).
  [[nodiscard]] Result<flow::Variant> blobListValue(uint16_t chan_id, const std::string& dir = {});
  // One BLOB_GET: at most `max_bytes` of `path` from `offset`, of `version` (0: the current one;
  // a version that was replaced is not_found). `data` starts after `head_room` bytes left for the
  // caller (a relay writes its own header there).
  struct BlobPiece {
    uint64_t version = 0, total_size = 0;
    std::string data;
  };
  [[nodiscard]] Result<BlobPiece> blobRead(uint16_t chan_id, const std::string& path,
                                           uint64_t version, uint64_t offset, uint32_t max_bytes,
                                           size_t head_room = 0);
  // One whole version of `path` (a reader never mixes two versions: when the file is replaced
  // during a download, the download goes on from the version it started with).
  [[nodiscard]] Result<std::string> blobGet(uint16_t chan_id, const std::string& path,
                                            const BlobProgress& progress = {});
  // The same into the local file `local` (written beside it, then renamed); returns its size.
  [[nodiscard]] Result<uint64_t> blobGetFile(uint16_t chan_id, const std::string& path,
                                             const std::string& local,
                                             const BlobProgress& progress = {});
  // The same, chunk by chunk into `sink` (each piece valid during the call; an error from it
  // ends the download): a file of any size without holding it. Returns its size.
  [[nodiscard]] Result<uint64_t> blobGetStream(
      uint16_t chan_id, const std::string& path,
      const std::function<Result<void>(std::string_view)>& sink, const BlobProgress& progress = {});
  // Uploads `data` as `path` (missing directories are made); returns the new version. Readers
  // see the old file until the last byte is on the hub's disk.
  [[nodiscard]] Result<uint64_t> blobPut(uint16_t chan_id, const std::string& path,
                                         std::string_view data, const BlobProgress& progress = {});
  // The same from the local file `local`. With `upload_id`: *upload_id != 0 resumes that upload
  // from where the hub got to (an interrupted one); the id is stored there as soon as the hub
  // gives it, so that a caller can resume after a lost connection.
  [[nodiscard]] Result<uint64_t> blobPutFile(uint16_t chan_id, const std::string& local,
                                             const std::string& path,
                                             const BlobProgress& progress = {},
                                             uint64_t* upload_id = nullptr);
  // Writes `data` at `offset` of an existing file, as a new whole version (a copy of the file).
  [[nodiscard]] Result<uint64_t> blobModify(uint16_t chan_id, const std::string& path,
                                            uint64_t offset, std::string_view data);
  [[nodiscard]] Result<void> blobMkdir(uint16_t chan_id, const std::string& path);
  [[nodiscard]] Result<void> blobRmdir(uint16_t chan_id, const std::string& path);
  [[nodiscard]] Result<void> blobRemove(uint16_t chan_id, const std::string& path);
  // Bytes moved per request, and requests sent ahead of their replies.
  static constexpr size_t kBlobChunk = 1u << 20;
  static constexpr int kBlobWindow = 8;

  // An administrator's command (protocol 1.1, docs/security.md): "flows", "kick"
  // {"connection": N}, "chan_rm" {"name": ...}, "db_rm" {"name": ...}. permission_denied unless
  // the account is an administrator; unsupported from a 1.0 hub.
  [[nodiscard]] Result<flow::Variant> admin(const std::string& command,
                                            const flow::Variant& args = flow::Variant());

 private:
  struct Reply {
    uint8_t code = 0;
    std::string body;
  };
  // A reply whose body is a view into the read buffer, valid until the next receive or close.
  struct ReplyView {
    uint8_t code = 0;
    std::string_view body;
  };
  explicit SyncClient(int fd, ConnectOptions options);
  template <class M>
  Result<Reply> request(const M& m, uint32_t timeout_ms);
  Result<Reply> roundTrip(const std::string& frame, uint32_t timeout_ms);
  // The two halves of a round trip, for requests sent ahead of their replies (blob transfers).
  Result<void> sendFrame(std::string_view frame, std::string_view more = {});
  Result<Reply> receiveReply(uint32_t timeout_ms);
  Result<ReplyView> receiveView(uint32_t timeout_ms);
  static Error hubError(flow::ErrorCode code, const std::string& body);
  // A pipelined upload from `read` (blobPut and blobPutFile).
  Result<uint64_t> upload(uint16_t chan_id, const std::string& path, uint64_t size,
                          const std::function<Result<std::string_view>(uint64_t, size_t)>& read,
                          const BlobProgress& progress, uint64_t* upload_id);
  Result<void> expectEmpty(Result<Reply> r);
  Result<flow::Variant> expectValue(Result<Reply> r);
  Error fail(Errc code, std::string message);

  int fd_ = -1;
  std::optional<flow::TlsSession> tls_;  // tls: addresses
  ConnectOptions options_;
  LoginInfo login_;
  flow::ErrorCode last_error_ = flow::ErrorCode::ok;
  std::unique_ptr<flow::InBuffer> in_;  // bytes from the hub not parsed yet
};

template <class M>
Result<SyncClient::Reply> SyncClient::request(const M& m, uint32_t timeout_ms) {
  std::string frame;
  if (!flow::encode(frame, m)) {
    return makeError(Errc::invalid_argument, "a name or key is longer than 65535 bytes");
  }
  return roundTrip(frame, timeout_ms);
}

}  // namespace skr::sat
