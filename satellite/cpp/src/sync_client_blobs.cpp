// SPDX-License-Identifier: Apache-2.0
// SyncClient's blob channel requests (protocol 1.3). Transfers keep kBlobWindow requests of
// kBlobChunk bytes ahead of their replies, so that the hub's disk and the socket overlap.
#include <skrobot/runtime/flow/bytes.h>
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/satellite/sync_client.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <deque>

namespace skr::sat {

namespace msg = flow::msg;
using flow::Code;
using flow::Variant;

namespace {

constexpr uint16_t kBlobMinor = 3;

Error unsupportedHub(const LoginInfo& login) {
  return makeError(Errc::unsupported, "this hub (FlowProtocol 1." + std::to_string(login.minor) +
                                          ") has no blob channels: they need 1." +
                                          std::to_string(kBlobMinor));
}

Error localError(const std::string& what, const std::string& path) {
  return makeError(errno == ENOENT ? Errc::not_found : Errc::io_error,
                   what + " " + path + ": " + std::strerror(errno));
}

}  // namespace

#define SKR_NEEDS_BLOBS() \
  if (login_.minor < kBlobMinor) return unsupportedHub(login_)

Result<ChannelInfo> SyncClient::createBlobChannel(const std::string& short_name) {
  SKR_NEEDS_BLOBS();
  auto r = request(msg::BlobCreate{short_name}, options_.timeout_ms);
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
  auto info = flow::decode<msg::ChannelInfoReply>(r->body);
  if (!info) return fail(Errc::protocol_error, info.error().message);
  return std::move(info->info);
}

Result<Variant> SyncClient::blobListValue(uint16_t chan_id, const std::string& dir) {
  SKR_NEEDS_BLOBS();
  return expectValue(request(msg::BlobList{chan_id, dir}, options_.timeout_ms));
}

Result<SyncClient::BlobPiece> SyncClient::blobRead(uint16_t chan_id, const std::string& path,
                                                   uint64_t version, uint64_t offset,
                                                   uint32_t max_bytes, size_t head_room) {
  SKR_NEEDS_BLOBS();
  std::string frame;
  if (!flow::encode(frame, msg::BlobGet{chan_id, path, version, offset, max_bytes})) {
    return makeError(Errc::invalid_argument, "the path is longer than 65535 bytes");
  }
  if (auto s = sendFrame(frame); !s) return s.error();
  auto r = receiveView(options_.timeout_ms);
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) {
    return hubError(last_error_, std::string(r->body));
  }
  auto d = flow::decode<msg::BlobData>(r->body);
  if (!d) return fail(Errc::protocol_error, "BLOB_GET: " + d.error().message);
  BlobPiece piece{d->version, d->total_size, {}};
  piece.data.reserve(head_room + d->data.bytes.size());
  piece.data.resize(head_room);
  piece.data.append(d->data.bytes);
  return piece;
}

Result<std::vector<SyncClient::BlobEntry>> SyncClient::blobList(uint16_t chan_id,
                                                                const std::string& dir) {
  auto v = blobListValue(chan_id, dir);
  if (!v) return v.error();
  std::vector<BlobEntry> out;
  const auto* list = v->asList();
  if (list == nullptr) return fail(Errc::protocol_error, "BLOB_LIST: expected a list");
  for (const auto& item : *list) {
    const auto* m = item.asMap();
    if (m == nullptr) return fail(Errc::protocol_error, "BLOB_LIST: expected maps");
    BlobEntry e;
    const auto field = [&](const char* key) -> const Variant* {
      auto it = m->find(key);
      return it == m->end() ? nullptr : &it->second;
    };
    if (const auto* n = field("name"); n && n->isString()) e.name = *n->asString();
    if (const auto* d = field("dir")) e.dir = d->asBool().value_or(false);
    if (const auto* s = field("size")) e.size = s->asUint64().value_or(0);
    if (const auto* t = field("mtime_ns")) e.mtime_ns = t->asInt64().value_or(0);
    if (const auto* ver = field("version")) e.version = ver->asUint64().value_or(0);
    out.push_back(std::move(e));
  }
  return out;
}

Result<std::string> SyncClient::blobGet(uint16_t chan_id, const std::string& path,
                                        const BlobProgress& progress) {
  std::string out;
  auto r = blobGetStream(
      chan_id, path,
      [&](std::string_view data) -> Result<void> {
        out.append(data);
        return {};
      },
      [&](uint64_t done, uint64_t total) {
        if (out.capacity() < total) out.reserve(total);  // once, when the size is known
        if (progress) progress(done, total);
      });
  if (!r) return r.error();
  return out;
}

Result<uint64_t> SyncClient::blobGetFile(uint16_t chan_id, const std::string& path,
                                         const std::string& local, const BlobProgress& progress) {
  const std::string part = local + ".part";
  const int fd = ::open(part.c_str(), O_CREAT | O_TRUNC | O_WRONLY | O_CLOEXEC, 0644);
  if (fd < 0) return localError("cannot write", part);
  auto r = blobGetStream(
      chan_id, path,
      [&](std::string_view data) -> Result<void> {
        while (!data.empty()) {
          const ssize_t n = ::write(fd, data.data(), data.size());
          if (n < 0 && errno == EINTR) continue;
          if (n < 0) return localError("cannot write", part);
          data.remove_prefix(size_t(n));
        }
        return {};
      },
      progress);
  const bool synced = r && ::fsync(fd) == 0;
  ::close(fd);
  if (!r || !synced || ::rename(part.c_str(), local.c_str()) != 0) {
    ::unlink(part.c_str());
    if (!r) return r.error();
    return localError("cannot write", local);
  }
  return *r;
}

Result<uint64_t> SyncClient::blobGetStream(
    uint16_t chan_id, const std::string& path,
    const std::function<Result<void>(std::string_view)>& sink, const BlobProgress& progress) {
  SKR_NEEDS_BLOBS();
  // The data is a view into the read buffer, valid until the next receive.
  const auto reply = [&](Result<ReplyView> r) -> Result<msg::BlobData> {
    if (!r) return r.error();
    if (r->code != static_cast<uint8_t>(Code::reply_ok)) {
      return hubError(last_error_, std::string(r->body));
    }
    auto d = flow::decode<msg::BlobData>(r->body);
    if (!d) return fail(Errc::protocol_error, "BLOB_GET: " + d.error().message);
    return d;
  };
  const auto ask = [&](uint64_t version, uint64_t offset) -> Result<void> {
    std::string frame;
    if (!flow::encode(frame, msg::BlobGet{chan_id, path, version, offset, uint32_t(kBlobChunk)})) {
      return makeError(Errc::invalid_argument, "the path is longer than 65535 bytes");
    }
    return sendFrame(frame);
  };
  // The first chunk gives the version and the size; the rest are asked ahead, of that version.
  if (auto s = ask(0, 0); !s) return s.error();
  auto first = reply(receiveView(options_.timeout_ms));
  if (!first) return first.error();
  const uint64_t version = first->version;
  const uint64_t total = first->total_size;
  uint64_t got = first->data.bytes.size();
  if (auto s = sink(first->data.bytes); !s) return s.error();
  if (progress) progress(got, total);
  uint64_t asked = got;
  int ahead = 0;
  Result<void> failed{};
  while (got < total) {
    while (failed && ahead < kBlobWindow && asked < total) {
      if (auto s = ask(version, asked); !s) return s.error();
      asked += std::min<uint64_t>(kBlobChunk, total - asked);
      ++ahead;
    }
    if (ahead == 0) break;
    auto d = reply(receiveView(options_.timeout_ms));
    --ahead;
    if (!d) {
      if (!isOpen()) return d.error();
      if (failed) failed = d.error();  // the replies still on their way are read, then it fails
      continue;
    }
    if (!failed) continue;
    if (d->version != version || d->data.bytes.empty()) {
      failed = fail(Errc::protocol_error, "BLOB_GET: an answer of another version or empty");
      continue;
    }
    got += d->data.bytes.size();
    if (auto s = sink(d->data.bytes); !s) failed = s.error();
    if (progress) progress(got, total);
  }
  if (!failed) return failed.error();
  return total;
}

Result<uint64_t> SyncClient::blobPut(uint16_t chan_id, const std::string& path,
                                     std::string_view data, const BlobProgress& progress) {
  return upload(
      chan_id, path, data.size(),
      [data](uint64_t offset, size_t n) -> Result<std::string_view> {
        return data.substr(size_t(offset), n);
      },
      progress, nullptr);
}

Result<uint64_t> SyncClient::blobPutFile(uint16_t chan_id, const std::string& local,
                                         const std::string& path, const BlobProgress& progress,
                                         uint64_t* upload_id) {
  const int fd = ::open(local.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return localError("cannot read", local);
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return makeError(Errc::invalid_argument, local + " is not a regular file");
  }
  std::string buf;
  auto r = upload(
      chan_id, path, uint64_t(st.st_size),
      [&](uint64_t offset, size_t n) -> Result<std::string_view> {
        buf.resize(n);
        size_t got = 0;
        while (got < n) {
          const ssize_t k = ::pread(fd, buf.data() + got, n - got, off_t(offset + got));
          if (k < 0 && errno == EINTR) continue;
          if (k < 0) return localError("cannot read", local);
          if (k == 0) return makeError(Errc::io_error, local + " shrank during the upload");
          got += size_t(k);
        }
        return std::string_view(buf);
      },
      progress, upload_id);
  ::close(fd);
  return r;
}

Result<uint64_t> SyncClient::upload(
    uint16_t chan_id, const std::string& path, uint64_t size,
    const std::function<Result<std::string_view>(uint64_t, size_t)>& read,
    const BlobProgress& progress, uint64_t* upload_id) {
  SKR_NEEDS_BLOBS();
  auto started = [&](uint64_t id) -> Result<msg::BlobPutOk> {
    auto r = request(msg::BlobPut{chan_id, path, size, id}, options_.timeout_ms);
    if (!r) return r.error();
    if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
    auto ok = flow::decode<msg::BlobPutOk>(r->body);
    if (!ok) return fail(Errc::protocol_error, "BLOB_PUT: " + ok.error().message);
    return *ok;
  };
  auto at = started(upload_id != nullptr ? *upload_id : 0);
  if (!at && upload_id != nullptr && *upload_id != 0 && at.error().code == Errc::not_found) {
    at = started(0);  // the hub no longer has it: from the start
  }
  if (!at) return at.error();
  if (upload_id != nullptr) *upload_id = at->upload_id;
  uint64_t sent = at->offset, acked = at->offset, version = 0;
  int ahead = 0;
  Result<void> failed{};
  bool empty_sent = false;  // an empty file is committed by one empty chunk
  for (;;) {
    while (failed && ahead < kBlobWindow && (sent < size || (size == 0 && !empty_sent))) {
      const size_t n = size_t(std::min<uint64_t>(kBlobChunk, size - sent));
      auto data = read(sent, n);
      if (!data) {
        failed = data.error();
        break;
      }
      // The frame's head, then the data sent from where it is (not copied into the frame).
      std::string head;
      (void)flow::encode(head, msg::BlobChunk{chan_id, at->upload_id, sent, msg::Rest{}});
      flow::ByteWriter(head).patchU32(0, static_cast<uint32_t>(head.size() - 4 + data->size()));
      if (auto s = sendFrame(head, *data); !s) return s.error();
      sent += n;
      empty_sent = true;
      ++ahead;
    }
    if (ahead == 0) break;
    auto r = receiveReply(options_.timeout_ms);
    --ahead;
    if (!r) return r.error();
    if (r->code != static_cast<uint8_t>(Code::reply_ok)) {
      if (failed) failed = hubError(last_error_, r->body);
      continue;
    }
    auto w = flow::decode<msg::BlobWritten>(r->body);
    if (!w) return fail(Errc::protocol_error, "BLOB_CHUNK: " + w.error().message);
    acked = w->received;
    if (w->version != 0) version = w->version;
    if (progress) progress(acked, size);
  }
  if (!failed) return failed.error();
  if (version == 0) return fail(Errc::protocol_error, "the upload ended without a version");
  if (upload_id != nullptr) *upload_id = 0;
  return version;
}

Result<uint64_t> SyncClient::blobModify(uint16_t chan_id, const std::string& path, uint64_t offset,
                                        std::string_view data) {
  SKR_NEEDS_BLOBS();
  auto r = request(msg::BlobModify{chan_id, path, offset, msg::Rest{data}}, options_.timeout_ms);
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
  auto w = flow::decode<msg::BlobWritten>(r->body);
  if (!w) return fail(Errc::protocol_error, "BLOB_MODIFY: " + w.error().message);
  return w->version;
}

Result<void> SyncClient::blobMkdir(uint16_t chan_id, const std::string& path) {
  SKR_NEEDS_BLOBS();
  return expectEmpty(request(msg::BlobMkdir{chan_id, path}, options_.timeout_ms));
}
Result<void> SyncClient::blobRmdir(uint16_t chan_id, const std::string& path) {
  SKR_NEEDS_BLOBS();
  return expectEmpty(request(msg::BlobRmdir{chan_id, path}, options_.timeout_ms));
}
Result<void> SyncClient::blobRemove(uint16_t chan_id, const std::string& path) {
  SKR_NEEDS_BLOBS();
  return expectEmpty(request(msg::BlobRemove{chan_id, path}, options_.timeout_ms));
}

#undef SKR_NEEDS_BLOBS

}  // namespace skr::sat
