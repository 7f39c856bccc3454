// SPDX-License-Identifier: Apache-2.0
// Blob channels across the hub (the store opened at start and its channels brought back, an owner
// that leaves and comes back, the change events) and the BLOB_* requests of a synchronous
// connection: each is checked here (the channel, who may read, who may write), run by the store on
// its thread, and answered when the store is done. Answers leave in the order of the requests: the
// store runs them in order, a refusal made here waits behind the answers before it, and any other
// request waits until every blob answer before it has left (Connection::pipelined).
#include "families/blobs/blobs_room.h"

#include "connection.h"
#include "families/links/hub_link.h"
#include "hub.h"
#include "io_relay.h"

#include <skrobot/runtime/log.h>

namespace skr::flow {

namespace {

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

// --- across the hub --------------------------------------------------------------------------

Result<void> BlobsRoom::start() {
  const ServerOptions& opt = hub_.opt;
  if (opt.data_dir.empty()) return {};  // blob channels are answered `unsupported`
  store_ = std::make_unique<BlobStore>(
      opt.data_dir / "blobs", BlobQuota{opt.blob_channel_bytes, opt.blob_channel_files},
      [&l = hub_.loop](std::function<void()> fn) { l.post(std::move(fn)); });
  auto stored = store_->open();
  if (!stored) return stored.error();
  for (uint32_t i = 0; i < opt.blob_io_threads; ++i) {
    io_.push_back(std::make_shared<IoThread>("flow-io" + std::to_string(i)));
  }
  for (const auto& s : *stored) {
    const std::string prefix = s.owner + ".";
    if (s.name.rfind(prefix, 0) != 0) {
      log::warn(kLogSource, "BLOB-STORE-SKIPPED",
                s.name + ": its owner file names " + s.owner + ", not the channel's user");
      continue;
    }
    auto added =
        hub_.channels.add(nullptr, s.owner, s.name.substr(prefix.size()), ChannelKind::blob, "");
    if (!added) {
      log::warn(kLogSource, "BLOB-STORE-SKIPPED", s.name + ": " + added.error().message);
      continue;
    }
    if (auto db = hub_.databases.createChannelDb(s.name, s.owner, 0, Variant()); !db) {
      (void)hub_.channels.erase(**added);
      return db.error();
    }
  }
  if (!stored->empty()) {
    log::info(kLogSource, "BLOB-STORES-LOADED",
              std::to_string(stored->size()) + " blob channels from " +
                  (opt.data_dir / "blobs").string());
  }
  return {};
}

void BlobsRoom::stop() noexcept {
  for (auto& io : io_) io->stop();  // the connections it served were closed before
  io_.clear();
  store_.reset();  // what was asked of the store runs first
}

void BlobsRoom::endpointLeft(Endpoint& e) {
  if (store_) store_->forget(e.id);
  for (const auto& link : hub_.links.all()) {
    if (link) link->forgetReader(e.id);  // null while that link is being destroyed
  }
}

void BlobsRoom::channelRemoved(const Channel& ch) {
  if (ch.kind != ChannelKind::blob || ch.far || !store_) return;
  store_->drop(ch.name, [name = ch.name](Result<void> r) {
    if (!r) {
      log::error(kLogSource, "BLOB-IO", "removing the files of " + name + ": " + r.error().message);
    }
  });
}

Channel* BlobsRoom::reattach(Endpoint& owner, const std::string& name, uint32_t tag) {
  Channel* ch = hub_.channels.findByName(name);
  if (ch == nullptr || ch->kind != ChannelKind::blob || ch->owner_user != owner.user) {
    return nullptr;  // none, or not this user's blob channel: add() says already_exists
  }
  if (ch->owner == nullptr && owner.receivesEvents()) {
    ch->owner = &owner;
    owner.owned.push_back(ch->id);
    hub_.databases.setChannelDbOwner(ch->name, owner.id);
    hub_.endpoints.forEachEventReceiver([&](Endpoint& e) {
      if (&e != &owner) e.onChannelHeader(*ch);
    });
  }
  if (owner.receivesEvents()) owner.onChannelAdded(*ch, tag);  // how it learns the id
  return ch;
}

void BlobsRoom::detach(Endpoint& owner, Channel& ch) {
  std::erase(owner.owned, ch.id);
  ch.owner = nullptr;
  hub_.databases.setChannelDbOwner(ch.name, 0);
  hub_.endpoints.forEachEventReceiver([&](Endpoint& e) {
    if (&e != &owner) e.onChannelHeader(ch);
  });
}

void BlobsRoom::made(const Channel& ch, uint32_t owner_id, uint32_t tag,
                     std::function<void(Result<void>)> stored) {
  // On disk, on the store's thread; a store that cannot be made takes the channel with it.
  store_->create(
      ch.name, ch.owner_user,
      [&hub = hub_, id = ch.id, hash = ch.hash, owner_id, tag,
       stored = std::move(stored)](Result<void> r) {
        Channel* now = hub.channels.find(id);
        if (!r && now != nullptr && now->hash == hash) {
          log::error(kLogSource, "BLOB-IO", "blob channel " + now->name + ": " + r.error().message);
          hub.channels.drop(*now);
          if (Endpoint* e = hub.endpoints.find(owner_id); e && e->receivesEvents()) {
            e->onError(Code::chan_add, tag, id, toErrorCode(r.error().code), r.error().message);
          }
        }
        if (stored) stored(r);
      });
}

Result<Channel*> BlobsRoom::channel(const Endpoint& e, uint16_t id, bool write) {
  Channel* ch = hub_.channels.find(id);
  if (ch == nullptr || ch->kind != ChannelKind::blob) {
    return makeError(Errc::not_found, "no blob channel with id " + std::to_string(id));
  }
  if (write && ch->far) {
    return makeError(Errc::permission_denied,
                     ch->name + " is a blob channel of another hub: its files are written there");
  }
  if (write && ch->owner_user != e.user) {
    return makeError(Errc::permission_denied,
                     "only " + ch->owner_user + " writes to the blob channel " + ch->name);
  }
  if (!write && !e.access->allows(Action::subscribe, ch->name)) {
    return accessDenied(e.user, Action::subscribe, ch->name);
  }
  return ch;
}

void BlobsRoom::changed(uint16_t id, uint64_t hash, const BlobEvent& event) {
  Channel* ch = hub_.channels.find(id);
  if (ch == nullptr || ch->hash != hash) return;
  log::info(kLogSource, "BLOB-CHANGED",
            ch->name + ": " + event.path + " " +
                (event.change == 1   ? "written (" + std::to_string(event.size) + " bytes)"
                 : event.change == 2 ? std::string("removed")
                 : event.change == 3 ? std::string("directory made")
                                     : std::string("directory removed")));
  for (Endpoint* s : std::vector<Endpoint*>(ch->subscribers)) {
    if (s != nullptr) s->onBlobChanged(*ch, event);
  }
}

// --- the requests ----------------------------------------------------------------------------

template <class T>
std::function<void(Result<T>)> BlobsRoom::later(Connection& c, Code code, uint64_t bytes,
                                                std::function<void(Connection&, Result<T>&)> then) {
  return c.pipelined<T>(bytes, [code, then = std::move(then)](Connection& c, Result<T>& r) {
    if (r) {
      then(c, r);
    } else {
      refuseNow(c, code, r.error());
    }
  });
}

void BlobsRoom::refuseNow(Connection& c, Code code, const Error& e) {
  const std::string line =
      c.describe() + ": " + std::string(codeName(uint8_t(code))) + " refused: " + e.message;
  if (e.code == Errc::io_error || e.code == Errc::internal) {
    log::error(kLogSource, "BLOB-IO", line);
  } else if (e.code != Errc::not_found) {
    log::warn(kLogSource, "BLOB-REFUSED", line);
  }
  c.replyError(toErrorCode(e.code), e.message);
}

void BlobsRoom::refuse(Connection& c, Code code, const Error& e) {
  // Behind the answers still to come (at once when there are none).
  c.pipelined<void>(0, [code, e](Connection& c, Result<void>&) { refuseNow(c, code, e); })({});
}

Channel* BlobsRoom::channelFor(Connection& c, Code code, uint16_t id, bool write) {
  auto ch = channel(c, id, write);
  if (!store_ && !(ch && (*ch)->far)) {  // another hub's are read through its link
    refuse(c, code, makeError(Errc::unsupported, "this hub keeps no files: it has no data_dir"));
    return nullptr;
  }
  if (!ch) {
    refuse(c, code, ch.error());
    return nullptr;
  }
  if ((*ch)->far && farLink(**ch) == nullptr) {
    refuse(c, code, makeError(Errc::not_found, "the link that showed " + (*ch)->name + " is gone"));
    return nullptr;
  }
  return *ch;
}

HubLink* BlobsRoom::farLink(const Channel& ch) const {
  if (!ch.far) return nullptr;
  return ch.owner != nullptr ? hub_.links.link(*ch.owner) : nullptr;
}

void BlobsRoom::admitted(Connection& c) {
  if (c.pipelineDepth() >= kMaxInFlight || c.pipelineBytes() >= kMaxInFlightBytes) {
    c.pausePipeline();
  }
}

void BlobsRoom::handle(Connection& c, msg::BlobCreate& m) {
  if (!store_) {
    return refuse(c, Code::blob_create,
                  makeError(Errc::unsupported, "this hub keeps no files: it has no data_dir"));
  }
  const std::string name = c.user + "." + m.short_name;
  auto answer = later<void>(c, Code::blob_create, 0, [name](Connection& c, Result<void>&) {
    const Channel* ch = c.hub().channels.findByName(name);
    if (ch == nullptr) {
      c.replyError(ErrorCode::not_found, "the blob channel " + name + " was removed");
    } else {
      c.send(msg::ChannelInfoReply{c.hub().channels.info(*ch)});
    }
  });
  auto r = hub_.channels.create(c, m.short_name, ChannelKind::blob, "", Variant(), 0, answer);
  // Refused at once (an existing channel of another kind or user, a rule, a limit): the refusal
  // still leaves behind the answers before it.
  if (!r) answer(r.error());
  admitted(c);
}

void BlobsRoom::handle(Connection& c, msg::BlobList& m) {
  Channel* ch = channelFor(c, Code::blob_list, m.chan_id, false);
  if (ch == nullptr) return;
  auto done = later<Variant>(c, Code::blob_list, 0, [](Connection& c, Result<Variant>& r) {
    c.send(msg::ReplyValue{std::move(r).value()});
  });
  if (HubLink* link = farLink(*ch)) {
    link->blobList(c.id, *ch, m.dir, std::move(done));
  } else {
    store_->list(ch->name, m.dir, std::move(done));
  }
  admitted(c);
}

void BlobsRoom::handle(Connection& c, msg::BlobGet& m) {
  Channel* ch = channelFor(c, Code::blob_get, m.chan_id, false);
  if (ch == nullptr) return;
  c.widenSendBuffer();
  // Room for the reply's header in a frame of the hub's limit.
  const uint32_t most =
      std::min<uint32_t>({m.max_bytes, BlobStore::kMaxChunk, hub_.opt.max_frame_bytes - 64});
  auto done = later<BlobStore::Read>(
      c, Code::blob_get, most, [](Connection& c, Result<BlobStore::Read>& r) {
        c.sendBlobData(r->version, r->total_size, std::move(r->data));
      });
  if (HubLink* link = farLink(*ch)) {
    link->blobGet(c.id, *ch, m.path, m.version, m.offset, most, blobDataHead(), std::move(done));
  } else {
    store_->get(c.id, ch->name, m.path, m.version, m.offset, most, blobDataHead(), std::move(done));
  }
  admitted(c);
}

void BlobsRoom::handle(Connection& c, msg::BlobPut& m) {
  Channel* ch = channelFor(c, Code::blob_put, m.chan_id, true);
  if (ch == nullptr) return;
  const BlobQuota quota{uint64_t(c.limits.blob_mib) << 20, c.limits.blob_files};
  store_->put(
      c.id, ch->name, quota, m.path, m.total_size, m.upload_id,
      later<BlobStore::PutAt>(c, Code::blob_put, 0, [](Connection& c, Result<BlobStore::PutAt>& r) {
        c.send(msg::BlobPutOk{r->upload_id, r->offset});
      }));
  admitted(c);
}

void BlobsRoom::handle(Connection& c, msg::BlobChunk& m) {
  Channel* ch = channelFor(c, Code::blob_chunk, m.chan_id, true);
  if (ch == nullptr) return;
  const uint64_t bytes = m.data.bytes.size();
  store_->chunk(c.id, ch->name, m.upload_id, m.offset, c.takeBody(m.data.bytes),
                later<BlobStore::Written>(
                    c, Code::blob_chunk, bytes,
                    [chan = ch->id, hash = ch->hash](Connection& c, Result<BlobStore::Written>& r) {
                      c.send(msg::BlobWritten{r->received, r->version});
                      if (r->event) c.hub().blobs.changed(chan, hash, *r->event);
                    }));
  admitted(c);
}

void BlobsRoom::handle(Connection& c, msg::BlobModify& m) {
  Channel* ch = channelFor(c, Code::blob_modify, m.chan_id, true);
  if (ch == nullptr) return;
  const BlobQuota quota{uint64_t(c.limits.blob_mib) << 20, c.limits.blob_files};
  const uint64_t bytes = m.data.bytes.size();
  store_->modify(ch->name, quota, m.path, m.offset, c.takeBody(m.data.bytes),
                 later<BlobStore::Written>(c, Code::blob_modify, bytes,
                                           [chan = ch->id, hash = ch->hash](
                                               Connection& c, Result<BlobStore::Written>& r) {
                                             c.send(msg::BlobWritten{r->received, r->version});
                                             if (r->event)
                                               c.hub().blobs.changed(chan, hash, *r->event);
                                           }));
  admitted(c);
}

void BlobsRoom::handle(Connection& c, msg::BlobAbort& m) {
  Channel* ch = channelFor(c, Code::blob_abort, m.chan_id, true);
  if (ch == nullptr) return;
  store_->abort(
      ch->name, m.upload_id,
      later<void>(c, Code::blob_abort, 0, [](Connection& c, Result<void>&) { c.replyOk(); }));
  admitted(c);
}

void BlobsRoom::changeFile(Connection& c, Code code, uint16_t chan_id, const std::string& path) {
  Channel* ch = channelFor(c, code, chan_id, true);
  if (ch == nullptr) return;
  auto done = later<BlobEvent>(
      c, code, 0, [chan = ch->id, hash = ch->hash](Connection& c, Result<BlobEvent>& r) {
        c.replyOk();
        c.hub().blobs.changed(chan, hash, *r);
      });
  if (code == Code::blob_mkdir) {
    store_->mkdir(ch->name, path, std::move(done));
  } else if (code == Code::blob_rmdir) {
    store_->rmdir(ch->name, path, std::move(done));
  } else {
    store_->remove(ch->name, path, std::move(done));
  }
  admitted(c);
}

void BlobsRoom::handle(Connection& c, msg::BlobMkdir& m) {
  changeFile(c, Code::blob_mkdir, m.chan_id, m.path);
}

void BlobsRoom::handle(Connection& c, msg::BlobRmdir& m) {
  changeFile(c, Code::blob_rmdir, m.chan_id, m.path);
}

void BlobsRoom::handle(Connection& c, msg::BlobRemove& m) {
  changeFile(c, Code::blob_remove, m.chan_id, m.path);
}

}  // namespace skr::flow
