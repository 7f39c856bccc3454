// Blob channels across the server's parts: the store opened at start and its channels brought
// back, an owner that leaves and comes back, and the change events to subscribers.
#include "server_impl.h"

#include <skrobot/core/log.h>

namespace skr::flow {

Result<void> FlowServer::Impl::startBlobs() {
  if (opt.data_dir.empty()) return {};  // blob channels are answered `unsupported`
  blobs = std::make_unique<BlobStore>(
      opt.data_dir / "blobs", BlobQuota{opt.blob_channel_bytes, opt.blob_channel_files},
      [&l = loop](std::function<void()> fn) { l.post(std::move(fn)); });
  auto stored = blobs->open();
  if (!stored) return stored.error();
  for (const auto& s : *stored) {
    const std::string prefix = s.owner + ".";
    if (s.name.rfind(prefix, 0) != 0) {
      log::warn(kLogSource, "BLOB-STORE-SKIPPED",
                s.name + ": its owner file names " + s.owner + ", not the channel's user");
      continue;
    }
    auto added =
        channels.add(nullptr, s.owner, s.name.substr(prefix.size()), ChannelKind::blob, "");
    if (!added) {
      log::warn(kLogSource, "BLOB-STORE-SKIPPED", s.name + ": " + added.error().message);
      continue;
    }
    if (auto db = databases.createChannelDb(s.name, s.owner, 0, Variant()); !db) {
      (void)channels.erase(**added);
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

Channel* FlowServer::Impl::reattachBlob(Endpoint& owner, const std::string& name, uint32_t tag) {
  Channel* ch = channels.findByName(name);
  if (ch == nullptr || ch->kind != ChannelKind::blob || ch->owner_user != owner.user) {
    return nullptr;  // none, or not this user's blob channel: add() says already_exists
  }
  if (ch->owner == nullptr && owner.receivesEvents()) {
    ch->owner = &owner;
    owner.owned.push_back(ch->id);
    databases.setChannelDbOwner(ch->name, owner.id);
    endpoints.forEachEventReceiver([&](Endpoint& e) {
      if (&e != &owner) e.onChannelHeader(*ch);
    });
  }
  if (owner.receivesEvents()) owner.onChannelAdded(*ch, tag);  // how it learns the id
  return ch;
}

void FlowServer::Impl::detachBlob(Endpoint& owner, Channel& ch) {
  std::erase(owner.owned, ch.id);
  ch.owner = nullptr;
  databases.setChannelDbOwner(ch.name, 0);
  endpoints.forEachEventReceiver([&](Endpoint& e) {
    if (&e != &owner) e.onChannelHeader(ch);
  });
}

Result<Channel*> FlowServer::Impl::blobChannel(const Endpoint& e, uint16_t id, bool write) {
  Channel* ch = channels.find(id);
  if (ch == nullptr || ch->kind != ChannelKind::blob) {
    return makeError(Errc::not_found, "no blob channel with id " + std::to_string(id));
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

void FlowServer::Impl::blobChanged(uint16_t id, uint64_t hash, const BlobEvent& event) {
  Channel* ch = channels.find(id);
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

}  // namespace skr::flow
