// SPDX-License-Identifier: Apache-2.0
// LocalClient: a module's satellite inside the hub. Same channels, no socket, no copies; its
// failures are the Results of the server's parts, so a module gets the Errc a satellite gets.
#include "server_impl.h"

#include "families/blobs/blob_path.h"

#include <skrobot/runtime/log.h>

#include <algorithm>
#include <unordered_map>

namespace skr::flow {

struct LocalClient::Impl final : Endpoint {
  Impl(Hub& s, LocalHandlers h) : server(s), handlers(std::move(h)) {}
  ~Impl() override = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  Impl(Impl&&) = delete;
  Impl& operator=(Impl&&) = delete;

  Hub& server;
  LocalHandlers handlers;
  std::unordered_map<std::string, uint32_t> follows;  // sync sources by name, and `every`
  std::vector<uint64_t> watches;                      // database watches, ended with the client

  [[nodiscard]] bool receivesEvents() const override { return true; }
  [[nodiscard]] bool congested() const override { return false; }
  [[nodiscard]] std::string describe() const override {
    return "module " + client_name + " (" + user + ")";
  }
  [[nodiscard]] const char* kind() const override { return "module"; }
  void onData(const Channel& ch, std::string_view payload) override {
    ++traffic.messages_out;
    traffic.bytes_out += payload.size();
    if (handlers.on_data) handlers.on_data(ch.id, payload);
  }
  void onSubscribers(const Channel& ch, bool first) override {
    if (handlers.on_subscribers) handlers.on_subscribers(ch.id, first);
  }
  void onRequest(const Channel& ch, uint64_t request, const std::string& command,
                 const std::string& requester, const Variant& value) override {
    if (handlers.on_request) {
      handlers.on_request(ch.id, request, command, requester, value);
    } else {
      (void)server.services.respond(*this, ch.id, request,
                                    Variant("this module answers no requests"));
    }
  }
  void onResponse(uint16_t chan_id, uint32_t tag, bool, ErrorCode error,
                  const Variant& value) override {
    if (handlers.on_response) handlers.on_response(chan_id, tag, toErrc(error), value);
  }
  void onChannelAdded(const Channel& ch, uint32_t) override {
    if (ch.kind == ChannelKind::sync) {
      if (auto f = follows.find(ch.name); f != follows.end()) followNow(ch, f->second);
    }
    if (handlers.on_channel) handlers.on_channel(ch.id, ch.name, ch.kind, ch.mime, true);
  }
  void onSyncPulse(const Channel& ch, uint64_t seq, uint64_t source_time_ns,
                   uint32_t dropped) override {
    if (handlers.on_sync_pulse) {
      handlers.on_sync_pulse(ch.id, seq, source_time_ns, dropped);
    } else {
      server.sync.done(*this, ch.id, seq);
    }
  }
  void followNow(const Channel& ch, uint32_t every) {
    if (auto r = server.sync.follow(*this, ch.id, every); !r) {
      log::warn(kLogSource, "FLOW-MODULE-ERROR",
                describe() + ": cannot follow " + ch.name + ": " + r.error().message);
    }
  }
  void onChannelRemoved(const Channel& ch) override {
    if (handlers.on_channel) handlers.on_channel(ch.id, ch.name, ch.kind, ch.mime, false);
  }
  void onChannelHeader(const Channel&) override {}
  void onError(Code command, uint32_t, uint16_t chan_id, ErrorCode error,
               const std::string& message) override {
    log::warn(kLogSource, "FLOW-MODULE-ERROR",
              describe() + ": " + std::string(codeName(static_cast<uint8_t>(command))) +
                  " on channel " + std::to_string(chan_id) + ": " +
                  std::string(errorCodeName(error)) + ": " + message);
  }
  void onDbChanged(const std::string&) override {}
  void onPhysical(const msg::EvPhysGrant& m) override {
    if (handlers.on_phys_grant) handlers.on_phys_grant(m);
  }
  void onPhysical(const msg::EvPhysRevoke& m) override {
    if (handlers.on_phys_revoke) handlers.on_phys_revoke(m);
  }
  void onPhysical(const msg::EvPhysRelay& m) override {
    if (handlers.on_phys_relay) handlers.on_phys_relay(m);
  }
  void onPhysical(const msg::EvPhysSwitch& m) override {
    if (handlers.on_phys_switch) handlers.on_phys_switch(m);
  }
  void onPhysical(const msg::EvPhysResume& m) override {
    if (handlers.on_phys_resume) handlers.on_phys_resume(m);
  }
  void onBlobChanged(const Channel& ch, const BlobEvent& ev) override {
    static constexpr const char* kChanges[] = {"", "written", "removed", "dir_added",
                                               "dir_removed"};
    if (!handlers.on_data || ev.change < 1 || ev.change > 4) return;
    const std::string json = variantToJsonText(Variant(Variant::Map{
        {"change", Variant(kChanges[ev.change])},
        {"path", Variant(ev.path)},
        {"size", Variant(ev.size)},
        {"version", Variant(ev.version)},
    }));
    handlers.on_data(ch.id, json);
  }
};

std::unique_ptr<LocalClient> FlowServer::attachLocal(const std::string& user,
                                                     const std::string& name,
                                                     LocalHandlers handlers,
                                                     std::shared_ptr<const AccessRules> access) {
  auto impl = std::make_unique<LocalClient::Impl>(*impl_, std::move(handlers));
  impl->user = user;
  impl->client_name = name;
  if (access) impl->access = std::move(access);
  impl_->endpoints.add(*impl);
  impl_->loggedIn(*impl);
  return std::make_unique<LocalClient>(std::move(impl));
}

std::shared_ptr<const AccessRules> FlowServer::accountAccess(const std::string& account) const {
  if (!impl_->session.auth || !impl_->session.auth->hasUser(account)) return nullptr;
  return impl_->session.auth->accessOf(account);
}

LocalClient::LocalClient(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

LocalClient::~LocalClient() {
  impl_->server.loop.debugRequireLoopThread("LocalClient::~LocalClient");
  for (uint64_t id : impl_->watches) impl_->server.databases.store().unwatch(id);
  impl_->server.removeEndpoint(*impl_);
}

const std::string& LocalClient::user() const noexcept {
  return impl_->user;
}
uint32_t LocalClient::id() const noexcept {
  return impl_->id;
}

Result<uint16_t> LocalClient::createChannel(const std::string& short_name, ChannelKind kind,
                                            const std::string& mime, const Variant& props) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::createChannel");
  auto r = impl_->server.channels.create(*impl_, short_name, kind, mime, props, 0);
  if (!r) return r.error();
  return (*r)->id;
}

Result<void> LocalClient::removeChannel(uint16_t chan_id) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::removeChannel");
  return impl_->server.channels.remove(*impl_, chan_id);
}

std::optional<uint16_t> LocalClient::findChannel(const std::string& name) const {
  impl_->server.loop.debugRequireLoopThread("LocalClient::findChannel");
  if (const Channel* ch = impl_->server.channels.findByName(name)) return ch->id;
  return std::nullopt;
}

std::vector<std::shared_ptr<const std::string>> LocalClient::retained(uint16_t chan_id) const {
  impl_->server.loop.debugRequireLoopThread("LocalClient::retained");
  std::vector<std::shared_ptr<const std::string>> out;
  if (const Channel* ch = impl_->server.channels.find(chan_id)) {
    for (const auto& [key, payload] : ch->retained) out.push_back(payload);
  }
  return out;
}

std::vector<LocalClient::ChannelInfo> LocalClient::channels() const {
  impl_->server.loop.debugRequireLoopThread("LocalClient::channels");
  std::vector<ChannelInfo> out;
  impl_->server.channels.forEach([&](const Channel& ch) {
    out.push_back(ChannelInfo{ch.id, ch.name, ch.kind, ch.mime});
  });
  return out;
}

Result<void> LocalClient::publish(uint16_t chan_id, std::string_view payload) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::publish");
  ++impl_->traffic.messages_in;
  impl_->traffic.bytes_in += payload.size();
  return impl_->server.channels.publish(*impl_, chan_id, payload);
}

void LocalClient::dropped(uint16_t chan_id) {
  ++impl_->traffic.dropped;
  if (const Channel* ch = impl_->server.channels.find(chan_id)) ++ch->dropped;
}

Result<void> LocalClient::publishRetained(uint16_t chan_id, std::string_view key,
                                          std::string_view payload) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::publishRetained");
  ++impl_->traffic.messages_in;
  impl_->traffic.bytes_in += payload.size();
  return impl_->server.channels.publishRetained(*impl_, chan_id, key, payload);
}

Result<void> LocalClient::clearRetained(uint16_t chan_id, std::optional<std::string_view> key) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::clearRetained");
  return impl_->server.channels.clearRetained(*impl_, chan_id, key);
}

Result<void> LocalClient::offerPaths(const msg::PhysOffer& m) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::offerPaths");
  return impl_->server.physical.offer(*impl_, m);
}

Result<void> LocalClient::countPaths(const msg::PhysCount& m) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::countPaths");
  return impl_->server.physical.count(*impl_, m);
}

Result<void> LocalClient::switchedPaths(const msg::PhysSwitched& m) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::switchedPaths");
  return impl_->server.physical.switched(*impl_, m);
}

Result<void> LocalClient::replayPaths(const msg::PhysReplay& m) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::replayPaths");
  return impl_->server.physical.replay(*impl_, m);
}

Result<void> LocalClient::pulse(uint16_t chan_id) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::pulse");
  return impl_->server.sync.pulse(*impl_, chan_id, static_cast<uint64_t>(monotonicNs()));
}

Result<void> LocalClient::follow(const std::string& name, uint32_t every) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::follow");
  const Channel* ch = impl_->server.channels.findByName(name);
  if (ch != nullptr) {
    if (auto r = impl_->server.sync.follow(*impl_, ch->id, every); !r) return r.error();
  }
  impl_->follows[name] = every;  // waits for the source, or follows it again when re-created
  return {};
}

void LocalClient::unfollow(const std::string& name) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::unfollow");
  impl_->follows.erase(name);
  if (const Channel* ch = impl_->server.channels.findByName(name)) {
    (void)impl_->server.sync.unfollow(*impl_, ch->id);
  }
}

void LocalClient::syncDone(uint16_t chan_id, uint64_t seq) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::syncDone");
  impl_->server.sync.done(*impl_, chan_id, seq);
}

Result<void> LocalClient::subscribe(const std::string& name) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::subscribe");
  ChannelsRoom& channels = impl_->server.channels;
  channels.want(name, impl_->id);
  if (const Channel* ch = channels.findByName(name)) {
    // A module is relayed: an owner that served only paths must publish to the hub again.
    return channels.subscribeAndTell(*impl_, ch->id);
  }
  return {};  // waits for the channel
}

void LocalClient::unsubscribe(const std::string& name) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::unsubscribe");
  ChannelsRoom& channels = impl_->server.channels;
  channels.unwant(name, impl_->id);
  if (const Channel* ch = channels.findByName(name)) {
    const uint16_t id = ch->id;
    if (channels.unsubscribe(*impl_, id)) impl_->server.physical.subscribersChanged(id);
  }
}

Result<void> LocalClient::request(uint16_t chan_id, uint32_t tag, const std::string& command,
                                  const Variant& value) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::request");
  return impl_->server.services.request(*impl_, chan_id, tag, false, 0, command, value);
}

Result<void> LocalClient::respond(uint16_t chan_id, uint64_t request, const Variant& value) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::respond");
  return impl_->server.services.respond(*impl_, chan_id, request, value);
}

std::optional<Variant> LocalClient::getVariable(const std::string& db, const std::string& key) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::getVariable");
  const PairDatabase* d = impl_->server.databases.store().find(db);
  if (d == nullptr) return std::nullopt;
  if (const Variant* v = d->get(key)) return *v;
  return std::nullopt;
}

Result<void> LocalClient::setVariable(const std::string& db, const std::string& key,
                                      const Variant& value) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::setVariable");
  return impl_->server.databases.setVar(*impl_, db, key, value);
}

std::optional<Variant> LocalClient::pairsOf(const std::string& db) const {
  impl_->server.loop.debugRequireLoopThread("LocalClient::pairsOf");
  const PairDatabase* d = impl_->server.databases.store().find(db);
  if (d == nullptr) return std::nullopt;
  return d->all();
}

Result<void> LocalClient::removeVariable(const std::string& db, const std::string& key) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::removeVariable");
  return impl_->server.databases.delVar(*impl_, db, key);
}

Result<uint64_t> LocalClient::watchDatabase(const std::string& db, DatabaseStore::ChangeFn fn) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::watchDatabase");
  DatabaseAccess& dbs = impl_->server.databases;
  if (!dbs.canRead(*impl_, db)) return accessDenied(impl_->user, Action::db_read, db);
  const uint64_t id = dbs.store().watch(db, std::move(fn));
  impl_->watches.push_back(id);
  return id;
}

void LocalClient::unwatchDatabase(uint64_t id) noexcept {
  impl_->server.loop.debugRequireLoopThread("LocalClient::unwatchDatabase");
  auto& w = impl_->watches;
  w.erase(std::remove(w.begin(), w.end(), id), w.end());
  impl_->server.databases.store().unwatch(id);
}

void LocalClient::syncDatabases(std::function<void(Result<void>)> done) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::syncDatabases");
  impl_->server.databases.store().barrier(std::move(done));
}

// --- blob channels: the checks of the blobs room (blobs_room.cpp), then the store
// -----------------------

namespace {
// The store, once the path is known to be one (a bad path is refused at once, not later).
Result<BlobStore*> blobStore(Hub& server, const std::string& path, bool root_ok) {
  if (server.blobs.store() == nullptr) {
    return makeError(Errc::unsupported, "this hub keeps no files: it has no data_dir");
  }
  if (auto parts = blob::splitPath(path, root_ok); !parts) return parts.error();
  return server.blobs.store();
}
}  // namespace

Result<void> LocalClient::blobList(uint16_t chan_id, const std::string& dir,
                                   std::function<void(Result<Variant>)> done) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::blobList");
  auto store = blobStore(impl_->server, dir, true);
  if (!store) return store.error();
  auto ch = impl_->server.blobs.channel(*impl_, chan_id, false);
  if (!ch) return ch.error();
  (*store)->list((*ch)->name, dir, std::move(done));
  return {};
}

Result<void> LocalClient::blobGet(uint16_t chan_id, const std::string& path, uint64_t max_bytes,
                                  std::function<void(Result<BlobFile>)> done) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::blobGet");
  auto store = blobStore(impl_->server, path, false);
  if (!store) return store.error();
  auto ch = impl_->server.blobs.channel(*impl_, chan_id, false);
  if (!ch) return ch.error();
  (*store)->readAll((*ch)->name, path, max_bytes,
                    [done = std::move(done)](Result<BlobStore::Read> r) {
                      if (!r) return done(r.error());
                      done(BlobFile{r->version, std::move(r->data)});
                    });
  return {};
}

Result<void> LocalClient::blobPut(uint16_t chan_id, const std::string& path, std::string data,
                                  std::function<void(Result<uint64_t>)> done) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::blobPut");
  auto store = blobStore(impl_->server, path, false);
  if (!store) return store.error();
  auto ch = impl_->server.blobs.channel(*impl_, chan_id, true);
  if (!ch) return ch.error();
  const BlobQuota quota{uint64_t(impl_->limits.blob_mib) << 20, impl_->limits.blob_files};
  // An upload of one chunk: started, then its data, then the change told to subscribers.
  Hub& server = impl_->server;
  const std::string name = (*ch)->name;
  const uint64_t size = data.size();
  const uint32_t writer = impl_->id;
  (*store)->put(writer, name, quota, path, size, 0,
                [&server, writer, name, id = chan_id, hash = (*ch)->hash, data = std::move(data),
                 done = std::move(done)](Result<BlobStore::PutAt> at) mutable {
                  if (!at) return done(at.error());
                  BlobStore* store = server.blobs.store();
                  if (store == nullptr) return done(makeError(Errc::closed, "the hub is stopping"));
                  store->chunk(
                      writer, name, at->upload_id, 0, std::move(data),
                      [&server, id, hash, done = std::move(done)](Result<BlobStore::Written> w) {
                        if (!w) return done(w.error());
                        if (w->event) server.blobs.changed(id, hash, *w->event);
                        done(w->version);
                      });
                });
  return {};
}

Result<void> LocalClient::blobDo(uint16_t chan_id, BlobOp op, const std::string& path,
                                 std::function<void(Result<void>)> done) {
  impl_->server.loop.debugRequireLoopThread("LocalClient::blobDo");
  auto store = blobStore(impl_->server, path, false);
  if (!store) return store.error();
  auto ch = impl_->server.blobs.channel(*impl_, chan_id, true);
  if (!ch) return ch.error();
  auto then = [&server = impl_->server, id = chan_id, hash = (*ch)->hash,
               done = std::move(done)](Result<BlobEvent> r) {
    if (!r) return done(r.error());
    server.blobs.changed(id, hash, *r);
    done({});
  };
  const std::string& name = (*ch)->name;
  if (op == BlobOp::mkdir) {
    (*store)->mkdir(name, path, std::move(then));
  } else if (op == BlobOp::rmdir) {
    (*store)->rmdir(name, path, std::move(then));
  } else {
    (*store)->remove(name, path, std::move(then));
  }
  return {};
}

}  // namespace skr::flow
