// The blob channel requests of a synchronous connection (protocol 1.3). Each is checked here
// (the channel, who may read, who may write), run by the store on its thread, and answered when
// the store is done. Up to kMaxBlobInFlight requests (and kMaxBlobBytes of their data) of one
// connection are in the hub at once, so that its disk work overlaps the socket's; past that its
// reading pauses. Answers leave in the order of the requests: the store runs them in order, a
// refusal made here waits behind the answers before it, and any other request waits until every
// blob answer before it has left.
#include "connection.h"

#include <skrobot/core/log.h>

#include <cstring>
#include <utility>

namespace skr::flow {

namespace {

constexpr uint32_t kMaxBlobInFlight = 8;
constexpr uint64_t kMaxBlobBytes = 8u << 20;

// The bytes of a BLOB_DATA frame before its data.
size_t blobDataHead() {
  static const size_t head = [] {
    std::string frame;
    (void)encode(frame, msg::BlobData{});
    return frame.size();
  }();
  return head;
}

}  // namespace

// A callback for the store that finds the connection again (if it is still there), answers, and
// lets the next requests in.
template <class T>
std::function<void(Result<T>)> Connection::blobLater(
    uint64_t bytes, std::function<void(Connection&, Result<T>&)> then) {
  ++blob_in_flight_;
  blob_bytes_ += bytes;
  return [&server = server_, id = id, bytes, then = std::move(then)](Result<T> r) {
    auto it = server.connections.find(id);
    if (it == server.connections.end()) return;
    Connection& c = *it->second;
    then(c, r);
    c.blobAnswered(bytes);
  };
}

void Connection::sendBlobData(uint64_t version, uint64_t total_size, std::string frame) {
  std::string head;
  (void)encode(head, msg::BlobData{version, total_size, {}});
  ByteWriter(head).patchU32(0, static_cast<uint32_t>(frame.size() - 4));
  std::memcpy(frame.data(), head.data(), head.size());
  ++traffic.messages_out;
  traffic.bytes_out += frame.size();
  if (out_.empty() && whole_.empty()) {
    out_.swap(frame);
  } else if (tls_) {
    out_.append(frame);  // encrypted with the rest at the next flush
  } else {
    // Queued whole rather than copied onto the output on the loop thread: what is in out_ goes
    // first, then this frame, then what comes after it.
    if (!out_.empty()) whole_.push_back(std::exchange(out_, std::string()));
    whole_.push_back(std::move(frame));
  }
  queued();
}

void Connection::widenSendBuffer() {
  if (wide_send_buffer_ || transport_ != Transport::unix_socket) return;
  wide_send_buffer_ = true;
  int size = 1 << 20;  // Linux doubles it (and caps it at net.core.wmem_max)
  (void)uv_send_buffer_size(reinterpret_cast<uv_handle_t*>(stream()), &size);
}

void Connection::blobAnswered(uint64_t bytes) {
  --blob_in_flight_;
  blob_bytes_ -= bytes;
  if (blob_waiting_) {
    blob_waiting_ = false;
    unblock();
  }
}

bool Connection::waitForBlobAnswers(uint8_t code) {
  if (state_ != State::sync || blob_in_flight_ == 0) return false;
  const CodeInfo* info = codeInfo(code);
  if (info != nullptr && info->family == Family::blobs && info->direction == Direction::to_hub) {
    return false;  // another blob request: in order with the others
  }
  blob_waiting_ = true;
  block();
  return true;
}

void Connection::blobRefusedInOrder(Code code, const Error& e) {
  if (blob_in_flight_ == 0) {
    blobRefused(code, e);
    return;
  }
  // Behind the answers still to come.
  auto answer =
      blobLater<void>(0, [code, e](Connection& c, Result<void>&) { c.blobRefused(code, e); });
  server_.blobs->barrier([answer = std::move(answer)] { answer({}); });
}

void Connection::blobRefused(Code code, const Error& e) {
  const std::string line =
      describe() + ": " + std::string(codeName(uint8_t(code))) + " refused: " + e.message;
  if (e.code == Errc::io_error || e.code == Errc::internal) {
    log::error(kLogSource, "BLOB-IO", line);
  } else if (e.code != Errc::not_found) {
    log::warn(kLogSource, "BLOB-REFUSED", line);
  }
  replyError(toErrorCode(e.code), e.message);
}

void Connection::handleBlob(Code code, std::string_view body) {
  const DecodeLimits dl{32, 1u << 20};
  BlobStore* store = server_.blobs.get();
  if (store == nullptr) {
    blobRefusedInOrder(code,
                       makeError(Errc::unsupported, "this hub keeps no files: it has no data_dir"));
    return;
  }
  const auto channel = [&](uint16_t chan_id, bool write) {
    return server_.blobChannel(*this, chan_id, write);
  };
  const BlobQuota quota{uint64_t(limits.blob_mib) << 20, limits.blob_files};
  // An answer sent as it is, or the refusal.
  const auto reply = [code](auto encode) {
    return [code, encode](Connection& c, auto& r) {
      if (r) {
        encode(c, r);
      } else {
        c.blobRefused(code, r.error());
      }
    };
  };
  // Answers to requests that change a file: the change reaches the channel's subscribers.
  const auto written = [&](const Channel& ch, uint64_t bytes) {
    return blobLater<BlobStore::Written>(
        bytes, reply([chan = ch.id, hash = ch.hash](Connection& c, Result<BlobStore::Written>& r) {
          c.send(msg::BlobWritten{r->received, r->version});
          if (r->event) c.server_.blobChanged(chan, hash, *r->event);
        }));
  };
  const auto changed = [&](const Channel& ch) {
    return blobLater<BlobEvent>(
        0, reply([chan = ch.id, hash = ch.hash](Connection& c, Result<BlobEvent>& r) {
          c.replyOk();
          c.server_.blobChanged(chan, hash, *r);
        }));
  };
  // Decodes the body as M, or closes the connection as a protocol breaker.
#define SKR_BLOB_DECODE(M, m)                                                           \
  auto m##_r = decode<M>(body, dl);                                                     \
  if (!m##_r) {                                                                         \
    protocolError(std::string(codeName(uint8_t(code))) + ": " + m##_r.error().message); \
    return;                                                                             \
  }                                                                                     \
  auto& m = m##_r.value();
#define SKR_BLOB_CHANNEL(ch, chan_id, write) \
  auto ch = channel(chan_id, write);         \
  if (!ch) {                                 \
    blobRefusedInOrder(code, ch.error());    \
    return;                                  \
  }

  switch (code) {
    case Code::blob_create: {
      SKR_BLOB_DECODE(msg::BlobCreate, m);
      const std::string name = user + "." + m.short_name;
      auto answer = blobLater<void>(0, reply([name](Connection& c, Result<void>&) {
                                      const Channel* ch = c.server_.channels.findByName(name);
                                      if (ch == nullptr) {
                                        c.replyError(ErrorCode::not_found,
                                                     "the blob channel " + name + " was removed");
                                      } else {
                                        c.send(msg::ChannelInfoReply{c.server_.info(*ch)});
                                      }
                                    }));
      auto r =
          server_.createChannel(*this, m.short_name, ChannelKind::blob, "", Variant(), 0, answer);
      // Refused at once (an existing channel of another kind or user, a rule, a limit): the
      // refusal still leaves behind the answers before it.
      if (!r) store->barrier([answer, e = r.error()] { answer(e); });
      break;
    }
    case Code::blob_list: {
      SKR_BLOB_DECODE(msg::BlobList, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, false);
      store->list((*ch)->name, m.dir,
                  blobLater<Variant>(0, reply([](Connection& c, Result<Variant>& r) {
                                       c.send(msg::ReplyValue{std::move(r).value()});
                                     })));
      break;
    }
    case Code::blob_get: {
      SKR_BLOB_DECODE(msg::BlobGet, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, false);
      widenSendBuffer();
      // Room for the reply's header in a frame of the hub's limit.
      const uint32_t most =
          std::min<uint32_t>({m.max_bytes, BlobStore::kMaxChunk, server_.opt.max_frame_bytes - 64});
      store->get(id, (*ch)->name, m.path, m.version, m.offset, most, blobDataHead(),
                 blobLater<BlobStore::Read>(
                     most, reply([](Connection& c, Result<BlobStore::Read>& r) {
                       c.sendBlobData(r->version, r->total_size, std::move(r->data));
                     })));
      break;
    }
    case Code::blob_put: {
      SKR_BLOB_DECODE(msg::BlobPut, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->put(
          (*ch)->name, quota, m.path, m.total_size, m.upload_id,
          blobLater<BlobStore::PutAt>(0, reply([](Connection& c, Result<BlobStore::PutAt>& r) {
                                        c.send(msg::BlobPutOk{r->upload_id, r->offset});
                                      })));
      break;
    }
    case Code::blob_chunk: {
      SKR_BLOB_DECODE(msg::BlobChunk, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->chunk((*ch)->name, m.upload_id, m.offset, takeBody(m.data.bytes),
                   written(**ch, m.data.bytes.size()));
      break;
    }
    case Code::blob_modify: {
      SKR_BLOB_DECODE(msg::BlobModify, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->modify((*ch)->name, quota, m.path, m.offset, takeBody(m.data.bytes),
                    written(**ch, m.data.bytes.size()));
      break;
    }
    case Code::blob_abort: {
      SKR_BLOB_DECODE(msg::BlobAbort, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->abort((*ch)->name, m.upload_id,
                   blobLater<void>(0, reply([](Connection& c, Result<void>&) { c.replyOk(); })));
      break;
    }
    case Code::blob_mkdir:
    case Code::blob_rmdir:
    case Code::blob_remove: {
      SKR_BLOB_DECODE(msg::BlobMkdir, m);  // the three share a layout: u16 channel, str16 path
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      if (code == Code::blob_mkdir) {
        store->mkdir((*ch)->name, m.path, changed(**ch));
      } else if (code == Code::blob_rmdir) {
        store->rmdir((*ch)->name, m.path, changed(**ch));
      } else {
        store->remove((*ch)->name, m.path, changed(**ch));
      }
      break;
    }
    default:
      blobRefusedInOrder(code, makeError(Errc::unsupported, std::string(codeName(uint8_t(code))) +
                                                                " is not implemented"));
      return;
  }
#undef SKR_BLOB_DECODE
#undef SKR_BLOB_CHANNEL
  // Enough in the hub for this connection: the next requests wait for answers.
  if (blob_in_flight_ >= kMaxBlobInFlight || blob_bytes_ >= kMaxBlobBytes) {
    blob_waiting_ = true;
    block();
  }
}

}  // namespace skr::flow
