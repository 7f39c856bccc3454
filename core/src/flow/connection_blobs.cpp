// The blob channel requests of a synchronous connection (protocol 1.3). Each is checked here
// (the channel, who may read, who may write), run by the store on its thread, and answered when
// the store is done; reading stays paused meanwhile, so one connection has one request in the hub
// at a time and a transfer moves at the pace of its replies.
#include "connection.h"

#include <skrobot/core/log.h>

namespace skr::flow {

namespace {

// A callback for the store that finds the connection again (if it is still there), answers, and
// resumes reading.
template <class T>
std::function<void(Result<T>)> later(FlowServer::Impl& server, uint32_t id,
                                     std::function<void(Connection&, Result<T>&)> then) {
  return [&server, id, then = std::move(then)](Result<T> r) {
    auto it = server.connections.find(id);
    if (it != server.connections.end()) then(*it->second, r);
  };
}

}  // namespace

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
    replyError(ErrorCode::unsupported, "this hub keeps no files: it has no data_dir");
    return;
  }
  const auto channel = [&](uint16_t chan_id, bool write) {
    return server_.blobChannel(*this, chan_id, write);
  };
  const BlobQuota quota{uint64_t(limits.blob_mib) << 20, limits.blob_files};
  // Answers to requests that change a file: the change reaches the channel's subscribers.
  const auto written = [&](const Channel& ch) {
    return later<BlobStore::Written>(
        server_, id,
        [code, chan = ch.id, hash = ch.hash](Connection& c, Result<BlobStore::Written>& r) {
          if (r) {
            c.send(msg::BlobWritten{r->received, r->version});
            if (r->event) c.server_.blobChanged(chan, hash, *r->event);
          } else {
            c.blobRefused(code, r.error());
          }
          c.unblock();
        });
  };
  const auto changed = [&](const Channel& ch) {
    return later<BlobEvent>(
        server_, id, [code, chan = ch.id, hash = ch.hash](Connection& c, Result<BlobEvent>& r) {
          if (r) {
            c.replyOk();
            c.server_.blobChanged(chan, hash, *r);
          } else {
            c.blobRefused(code, r.error());
          }
          c.unblock();
        });
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
    blobRefused(code, ch.error());           \
    return;                                  \
  }                                          \
  block();

  switch (code) {
    case Code::blob_create: {
      SKR_BLOB_DECODE(msg::BlobCreate, m);
      const std::string name = user + "." + m.short_name;
      block();
      auto r = server_.createChannel(
          *this, m.short_name, ChannelKind::blob, "", Variant(), 0,
          later<void>(server_, id, [name](Connection& c, Result<void>& done) {
            const Channel* ch = c.server_.channels.findByName(name);
            if (!done) {
              c.blobRefused(Code::blob_create, done.error());
            } else if (ch == nullptr) {
              c.replyError(ErrorCode::not_found, "the blob channel " + name + " was removed");
            } else {
              c.send(msg::ChannelInfoReply{c.server_.info(*ch)});
            }
            c.unblock();
          }));
      if (!r) {  // an existing channel of another kind or user, a rule, a limit
        blobRefused(code, r.error());
        unblock();
      }
      return;
    }
    case Code::blob_list: {
      SKR_BLOB_DECODE(msg::BlobList, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, false);
      store->list((*ch)->name, m.dir,
                  later<Variant>(server_, id, [code](Connection& c, Result<Variant>& r) {
                    if (r) {
                      c.send(msg::ReplyValue{std::move(r).value()});
                    } else {
                      c.blobRefused(code, r.error());
                    }
                    c.unblock();
                  }));
      return;
    }
    case Code::blob_get: {
      SKR_BLOB_DECODE(msg::BlobGet, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, false);
      // Room for the reply's header in a frame of the hub's limit.
      const uint32_t most =
          std::min<uint32_t>({m.max_bytes, BlobStore::kMaxChunk, server_.opt.max_frame_bytes - 64});
      store->get(
          id, (*ch)->name, m.path, m.version, m.offset, most,
          later<BlobStore::Read>(server_, id, [code](Connection& c, Result<BlobStore::Read>& r) {
            if (r) {
              c.send(msg::BlobData{r->version, r->total_size, msg::Rest{r->data}});
            } else {
              c.blobRefused(code, r.error());
            }
            c.unblock();
          }));
      return;
    }
    case Code::blob_put: {
      SKR_BLOB_DECODE(msg::BlobPut, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->put(
          (*ch)->name, quota, m.path, m.total_size, m.upload_id,
          later<BlobStore::PutAt>(server_, id, [code](Connection& c, Result<BlobStore::PutAt>& r) {
            if (r) {
              c.send(msg::BlobPutOk{r->upload_id, r->offset});
            } else {
              c.blobRefused(code, r.error());
            }
            c.unblock();
          }));
      return;
    }
    case Code::blob_chunk: {
      SKR_BLOB_DECODE(msg::BlobChunk, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->chunk((*ch)->name, m.upload_id, m.offset, std::string(m.data.bytes), written(**ch));
      return;
    }
    case Code::blob_modify: {
      SKR_BLOB_DECODE(msg::BlobModify, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->modify((*ch)->name, quota, m.path, m.offset, std::string(m.data.bytes), written(**ch));
      return;
    }
    case Code::blob_abort: {
      SKR_BLOB_DECODE(msg::BlobAbort, m);
      SKR_BLOB_CHANNEL(ch, m.chan_id, true);
      store->abort(
          (*ch)->name, m.upload_id,
          later<void>(server_, id, [](Connection& c, Result<void>& r) { c.answerDone(r); }));
      return;
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
      return;
    }
    default:
      replyError(ErrorCode::unsupported,
                 std::string(codeName(uint8_t(code))) + " is not implemented");
      return;
  }
#undef SKR_BLOB_DECODE
#undef SKR_BLOB_CHANNEL
}

}  // namespace skr::flow
