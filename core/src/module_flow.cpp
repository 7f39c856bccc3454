// SPDX-License-Identifier: Apache-2.0
#include "module_flow.h"

#include "module_record.h"
#include "paths.h"  // the runtime's physical mode (its owner side serves a module's paths)

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/log.h>

#include <algorithm>
#include <cstring>

namespace skr {
namespace {

Result<flow::Variant> fromJson(const char* json) {
  if (json == nullptr || *json == '\0') return flow::Variant();
  return flow::variantFromJsonText(json);
}

}  // namespace

ModuleFlow::ModuleFlow(flow::FlowServer& server, const std::string& module_name,
                       std::shared_ptr<const flow::AccessRules> access)
    : name_(module_name) {
  flow::LocalHandlers h;
  h.on_data = [this](uint16_t chan_id, std::string_view payload) {
    // Index loop: a callback may subscribe or unsubscribe.
    for (size_t i = 0; i < subs_.size(); ++i) {
      const Sub s = subs_[i];
      if (s.chan_id != chan_id) continue;
      if (!live_) {
        s.fn(s.user, chan_id, payload.data(), payload.size());
        continue;
      }
      if (!roomFor(chan_id, payload.size())) continue;
      deliver(
          s.handle,
          [s, chan_id, data = std::string(payload)] {
            s.fn(s.user, chan_id, data.data(), data.size());
          },
          payload.size());
    }
  };
  h.on_subscribers = [this](uint16_t chan_id, bool first) {
    if (creating_ && owned_.find(chan_id) == owned_.end()) owned_[chan_id] = *creating_;
    auto it = owned_.find(chan_id);
    if (it == owned_.end() || it->second.on_subscribers == nullptr) return;
    const Owned o = it->second;
    if (!live_) return o.on_subscribers(o.user, chan_id, first ? 1 : 0);
    deliver(o.key, [o, chan_id, first] { o.on_subscribers(o.user, chan_id, first ? 1 : 0); });
  };
  h.on_request = [this](uint16_t chan_id, uint64_t request, const std::string& command,
                        const std::string& requester, const flow::Variant& value) {
    auto it = owned_.find(chan_id);
    if (it == owned_.end() || it->second.on_request == nullptr) {
      (void)client_->respond(chan_id, request, flow::Variant("this channel takes no requests"));
      return;
    }
    const Owned o = it->second;
    std::string json = flow::variantToJsonText(value);
    if (!live_) {
      return o.on_request(o.user, chan_id, request, command.c_str(), requester.c_str(),
                          json.c_str());
    }
    deliver(o.key, [o, chan_id, request, command, requester, json = std::move(json)] {
      o.on_request(o.user, chan_id, request, command.c_str(), requester.c_str(), json.c_str());
    });
  };
  h.on_response = [this](uint16_t chan_id, uint32_t tag, Errc error, const flow::Variant& value) {
    auto it = pending_.find(tag);
    if (it == pending_.end()) return;
    const Pending p = it->second;
    pending_.erase(it);
    if (p.fn == nullptr) return;
    std::string json = flow::variantToJsonText(value);
    if (!live_) return p.fn(p.user, chan_id, p.tag, toStatus(error), json.c_str());
    deliver(0, [p, chan_id, status = toStatus(error), json = std::move(json)] {
      p.fn(p.user, chan_id, p.tag, status, json.c_str());
    });
  };
  h.on_channel = [this](uint16_t chan_id, const std::string& name, flow::ChannelKind kind,
                        const std::string& mime, bool added) {
    for (Sub& s : subs_) {
      if (s.name == name) s.chan_id = added ? chan_id : 0;
    }
    for (Follow& f : follows_) {
      if (f.name == name) f.chan_id = added ? chan_id : 0;
    }
    // Index loop on a copy: a watcher may watch or unwatch from its call.
    const std::vector<ChannelWatch> watches = channel_watches_;
    for (const ChannelWatch& w : watches) {
      if (!isWatching(w.handle)) continue;
      if (!live_) {
        w.fn(w.user, chan_id, name.c_str(), static_cast<skr_channel_kind>(kind), mime.c_str(),
             added ? 1 : 0);
        continue;
      }
      deliver(w.handle, [w, chan_id, name, kind, mime, added] {
        w.fn(w.user, chan_id, name.c_str(), static_cast<skr_channel_kind>(kind), mime.c_str(),
             added ? 1 : 0);
      });
    }
  };
  h.on_sync_pulse = [this](uint16_t chan_id, uint64_t seq, uint64_t source_time_ns,
                           uint32_t dropped) {
    auto it = std::find_if(follows_.begin(), follows_.end(),
                           [&](const Follow& f) { return f.chan_id == chan_id; });
    if (it == follows_.end()) return client_->syncDone(chan_id, seq);
    const Follow f = *it;  // the handler may unfollow
    f.fn(f.user, chan_id, seq, source_time_ns, dropped);
    if ((f.flags & SKR_SYNC_DONE_LATER) == 0) client_->syncDone(chan_id, seq);
  };
  h.on_phys_grant = [this](const flow::msg::EvPhysGrant& m) {
    if (paths_) paths_->onGrant(m);
  };
  h.on_phys_revoke = [this](const flow::msg::EvPhysRevoke& m) {
    if (paths_) paths_->onRevoke(m);
  };
  h.on_phys_relay = [this](const flow::msg::EvPhysRelay& m) {
    if (paths_) paths_->onRelay(m);
  };
  h.on_phys_switch = [this](const flow::msg::EvPhysSwitch& m) {
    if (paths_) paths_->onSwitch(m);
  };
  h.on_phys_resume = [this](const flow::msg::EvPhysResume& m) {
    if (paths_) paths_->onResume(m);
  };
  client_ = server.attachLocal(module_name, module_name, std::move(h), std::move(access));
}

ModuleFlow::~ModuleFlow() {
  if (live_) {  // nothing still posted to the module's thread runs
    std::lock_guard lock(live_->mutex);
    live_->keys.clear();
  }
  // Paths first: their peers are told BYE and their subscribers fall back to the relay before
  // the channels go with the client.
  if (paths_loop_ != nullptr) paths_loop_->removeTickHandler(paths_tick_);
  paths_.reset();
  // The module stops before its barriers and blob calls were answered: each gets its one call.
  for (const auto& [id, done] : std::exchange(syncs_, {}))
    done.first(done.second, SKR_ERR_BAD_STATE);
  static constexpr char kStopped[] = "the module stopped first";
  for (const auto& [id, done] : std::exchange(blobs_, {}))
    done.first(done.second, SKR_ERR_BAD_STATE, kStopped, sizeof kStopped, 0);
}

void ModuleFlow::deliverOn(Loop& module_loop) {
  deliver_loop_ = &module_loop;
  live_ = std::make_shared<Live>();
  live_->add(0);
}

void ModuleFlow::deliver(skr_sub_handle key, std::function<void()> call, size_t bytes) {
  live_->behind += bytes;
  deliver_loop_->post([live = live_, key, call = std::move(call), bytes] {
    if (live->has(key)) call();
    live->behind -= bytes;
  });
}

bool ModuleFlow::roomFor(uint16_t chan_id, size_t bytes) {
  if (live_->behind.load() + bytes <= kMaxBehindBytes) return true;
  client_->dropped(chan_id);
  ++behind_dropped_;
  const Nanos now = monotonicNs();
  if (now - behind_logged_ >= kNsPerSec) {
    log::warn("mod." + name_, "MODULE-BEHIND",
              "its thread is " + std::to_string(live_->behind.load() >> 20) +
                  " MiB of messages behind: " + std::to_string(behind_dropped_) +
                  " dropped since the last line (at most " + std::to_string(kMaxBehindBytes >> 20) +
                  " MiB wait for a module's thread)");
    behind_logged_ = now;
    behind_dropped_ = 0;
  }
  return false;
}

skr_status ModuleFlow::fail(const std::string& what, const Error& error) const {
  log::warn("mod." + name_, "MODULE-FLOW", what + ": " + error.message);
  return toStatus(error.code);
}

skr_status ModuleFlow::createChannel(const char* short_name, skr_channel_kind kind,
                                     const char* mime, const char* props_json,
                                     skr_subscribers_fn on_subscribers, skr_request_fn on_request,
                                     void* user, uint16_t* chan_id_out) {
  if (short_name == nullptr || chan_id_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  auto props = fromJson(props_json);
  if (!props) return fail("channel_create " + std::string(short_name), props.error());
  // A waiting subscription may attach during creation: the callbacks must be known by then.
  const skr_sub_handle key = next_handle_++;
  live(key);
  creating_ = Owned{on_subscribers, on_request, user, key};
  auto r = client_->createChannel(short_name, static_cast<flow::ChannelKind>(kind),
                                  mime != nullptr ? mime : "", *props);
  creating_.reset();
  if (!r) {
    gone(key);
    return fail("channel_create " + std::string(short_name), r.error());
  }
  owned_[*r] = Owned{on_subscribers, on_request, user, key};
  *chan_id_out = *r;
  return SKR_OK;
}

skr_status ModuleFlow::removeChannel(uint16_t chan_id) {
  auto r = client_->removeChannel(chan_id);
  if (!r) return fail("channel_remove", r.error());
  if (auto it = owned_.find(chan_id); it != owned_.end()) gone(it->second.key);
  owned_.erase(chan_id);
  begun_.erase(chan_id);
  if (paths_) paths_->unserve(chan_id);
  return SKR_OK;
}

skr_status ModuleFlow::findChannel(const char* name, uint16_t* chan_id_out) const {
  if (name == nullptr || chan_id_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  auto id = client_->findChannel(name);
  if (!id) return SKR_ERR_NOT_FOUND;
  *chan_id_out = *id;
  return SKR_OK;
}

skr_status ModuleFlow::publish(uint16_t chan_id, const void* data, size_t size) {
  if (data == nullptr && size > 0) return SKR_ERR_INVALID_ARGUMENT;
  const std::string_view payload(static_cast<const char*>(data), data != nullptr ? size : 0);
  if (paths_ && paths_->serves(chan_id)) {
    begun_.erase(chan_id);  // the ring's next slot may be the one publish_begin gave
    // Copied into a slot and onto direct sockets; the hub only while someone is relayed (what
    // it does not get is counted by the paths' PHYS_COUNT each second).
    if (!paths_->publish(chan_id, payload, 0)) return SKR_OK;
  }
  auto r = client_->publish(chan_id, payload);
  return r ? SKR_OK : fail("publish", r.error());
}

// --- physical mode (ABI 1.7) ------------------------------------------------------------------

skr_status ModuleFlow::offerPaths(Loop& loop, uint16_t chan_id, const skr_path_options* options) {
  if (options == nullptr || options->struct_size < offsetof(skr_path_options, ring_slots)) {
    return SKR_ERR_INVALID_ARGUMENT;
  }
  skr_path_options o{};  // a module built with a shorter struct gets the defaults for the rest
  std::memcpy(&o, options, std::min<size_t>(options->struct_size, sizeof o));
  if ((o.kinds & (SKR_PATH_DIRECT | SKR_PATH_SHM)) == 0 ||
      (o.kinds & ~uint32_t(SKR_PATH_DIRECT | SKR_PATH_SHM)) != 0) {
    return fail("channel_paths", makeError(Errc::invalid_argument,
                                           "kinds must be SKR_PATH_DIRECT and/or SKR_PATH_SHM"));
  }
  if (owned_.find(chan_id) == owned_.end()) {
    return fail("channel_paths", makeError(Errc::not_found, "not a channel of this module"));
  }
  if (paths_ && paths_->serves(chan_id)) {
    return fail("channel_paths", makeError(Errc::invalid_argument, "paths offered already"));
  }
  std::string name;
  for (const auto& ch : client_->channels()) {
    if (ch.id == chan_id && ch.kind == flow::ChannelKind::streaming) name = ch.name;
  }
  if (name.empty()) {  // checked before a ring or a listener is made for it
    return fail("channel_paths", makeError(Errc::invalid_argument, "not a streaming channel"));
  }
  if (!paths_) {
    flow::phys::Paths::Host h;
    h.loop = &loop;
    h.offer = [this](const flow::msg::PhysOffer& m) {
      auto r = client_->offerPaths(m);
      offered_ = true;
      if (!r) offer_error_ = r.error();
    };
    h.count = [this](const flow::msg::PhysCount& m) {
      if (auto r = client_->countPaths(m); !r) (void)fail("paths", r.error());
    };
    h.switched = [this](const flow::msg::PhysSwitched& m) {
      if (auto r = client_->switchedPaths(m); !r) (void)fail("paths", r.error());
    };
    h.replay = [this](const flow::msg::PhysReplay& m) {
      if (auto r = client_->replayPaths(m); !r) (void)fail("paths", r.error());
    };
    // A module takes no paths as a subscriber: these are never called.
    h.request = [](const flow::msg::PhysRequest&) {};
    h.state = [](const flow::msg::PhysState&) {};
    h.fallback = [](const flow::msg::PhysFallback&) {};
    h.received = [](const flow::msg::PhysReceived&) {};
    h.deliver_view = [](uint16_t, std::string_view) {};
    h.wants_copy = [] { return false; };
    h.deliver_copy = [](uint16_t, std::string) {};
    h.next_tag = [this] { return next_path_tag_++; };
    h.hub_minor = [] { return flow::kProtocolMinor; };  // no TCP endpoint (tcp_listen is "")
    paths_ = std::make_unique<flow::phys::Paths>(std::move(h));
    paths_loop_ = &loop;
    paths_tick_ = loop.addTickHandler(Tick::one_sec, [this] { paths_->tick(); });
  }
  const auto kinds = uint8_t(((o.kinds & SKR_PATH_DIRECT) != 0 ? flow::msg::kPhysDirect : 0) |
                             ((o.kinds & SKR_PATH_SHM) != 0 ? flow::msg::kPhysShm : 0));
  flow::shm::RingGeometry ring;
  if (o.ring_slots != 0) ring.slots = o.ring_slots;
  if (o.ring_readers != 0) ring.max_readers = o.ring_readers;
  if (o.slot_bytes != 0) ring.slot_bytes = o.slot_bytes;
  offered_ = false;
  offer_error_.reset();
  paths_->serve(chan_id, name, kinds, ring);
  if (offer_error_) {
    paths_->unserve(chan_id);
    return fail("channel_paths " + name, *offer_error_);
  }
  if (!offered_) {
    paths_->unserve(chan_id);
    return fail("channel_paths " + name,
                makeError(Errc::unsupported, "no path can be served (see SAT-PATH above)"));
  }
  return SKR_OK;
}

skr_status ModuleFlow::publishRetained(uint16_t chan_id, const char* key, const void* data,
                                       size_t size) {
  if (key == nullptr || (data == nullptr && size > 0)) return SKR_ERR_INVALID_ARGUMENT;
  const std::string_view payload(static_cast<const char*>(data), data != nullptr ? size : 0);
  if (paths_ && paths_->serves(chan_id)) {
    // Subscribers on paths get it there now (the relayed ones from the hub, below); one that
    // subscribes later gets it from the hub.
    begun_.erase(chan_id);
    (void)paths_->publish(chan_id, payload, 0);
  }
  auto r = client_->publishRetained(chan_id, key, payload);
  return r ? SKR_OK : fail("publish_retained", r.error());
}

skr_status ModuleFlow::retainClear(uint16_t chan_id, const char* key) {
  auto r = key != nullptr ? client_->clearRetained(chan_id, std::string_view(key))
                          : client_->clearRetained(chan_id, std::nullopt);
  return r ? SKR_OK : fail("retain_clear", r.error());
}

skr_status ModuleFlow::publishBegin(uint16_t chan_id, void** slot_out, size_t* capacity_out) {
  if (slot_out == nullptr || capacity_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  if (!paths_ || !paths_->hasRing(chan_id)) return SKR_ERR_NOT_FOUND;
  const auto slot = paths_->beginPublish(chan_id);
  if (slot.empty()) return SKR_ERR_BAD_STATE;  // every slot is being read
  begun_[chan_id] = slot.size();
  *slot_out = slot.data();
  *capacity_out = slot.size();
  return SKR_OK;
}

skr_status ModuleFlow::publishCommit(uint16_t chan_id, size_t size, int64_t capture_ns) {
  auto b = begun_.find(chan_id);
  if (b == begun_.end() || !paths_) return SKR_ERR_BAD_STATE;
  if (size > b->second) return SKR_ERR_INVALID_ARGUMENT;
  begun_.erase(b);
  bool relay = false;
  const auto bytes = paths_->commitPublish(chan_id, size, capture_ns, relay);
  if (!bytes) return SKR_ERR_FAILED;
  if (!relay) return SKR_OK;
  auto r = client_->publish(chan_id, *bytes);
  return r ? SKR_OK : fail("publish_commit", r.error());
}

skr_status ModuleFlow::subscribe(const char* name, skr_data_fn fn, void* user,
                                 skr_sub_handle* handle_out) {
  if (name == nullptr || fn == nullptr || handle_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  const skr_sub_handle handle = next_handle_++;
  live(handle);
  const bool again =
      std::any_of(subs_.begin(), subs_.end(), [name](const Sub& s) { return s.name == name; });
  const uint16_t chan_id = client_->findChannel(name).value_or(0);
  subs_.push_back(Sub{handle, name, chan_id, fn, user});
  if (auto r = client_->subscribe(name); !r) {
    gone(handle);
    subs_.pop_back();
    return fail("subscribe " + std::string(name), r.error());
  }
  *handle_out = handle;
  // The hub has one subscription of this module per channel, and handed the retained messages
  // to the first Sub only: this one gets them here, before anything live.
  if (again && chan_id != 0) {
    for (const auto& payload : client_->retained(chan_id)) {
      const bool still = std::any_of(subs_.begin(), subs_.end(),
                                     [handle](const Sub& s) { return s.handle == handle; });
      if (!still) break;  // unsubscribed from its own call
      if (!live_) {
        fn(user, chan_id, payload->data(), payload->size());
        continue;
      }
      if (!roomFor(chan_id, payload->size())) continue;
      deliver(
          handle,
          [fn, user, chan_id, payload] { fn(user, chan_id, payload->data(), payload->size()); },
          payload->size());
    }
  }
  return SKR_OK;
}

skr_status ModuleFlow::unsubscribe(skr_sub_handle handle) {
  auto it = std::find_if(subs_.begin(), subs_.end(),
                         [handle](const Sub& s) { return s.handle == handle; });
  if (it == subs_.end()) return SKR_ERR_NOT_FOUND;
  const std::string name = it->name;
  gone(handle);
  subs_.erase(it);
  const bool still =
      std::any_of(subs_.begin(), subs_.end(), [&name](const Sub& s) { return s.name == name; });
  if (!still) client_->unsubscribe(name);
  return SKR_OK;
}

skr_status ModuleFlow::request(uint16_t chan_id, uint32_t tag, const char* command,
                               const char* value_json, skr_response_fn fn, void* user) {
  auto value = fromJson(value_json);
  if (!value) return fail("service_request", value.error());
  const uint32_t internal = next_tag_++;
  pending_[internal] = Pending{tag, fn, user};
  auto r = client_->request(chan_id, internal, command != nullptr ? command : "", *value);
  if (!r) {
    pending_.erase(internal);
    return fail("service_request", r.error());
  }
  return SKR_OK;
}

skr_status ModuleFlow::respond(uint16_t chan_id, uint64_t request, const char* value_json) {
  auto value = fromJson(value_json);
  if (!value) return fail("service_respond", value.error());
  auto r = client_->respond(chan_id, request, *value);
  return r ? SKR_OK : fail("service_respond", r.error());
}

skr_status ModuleFlow::dbGet(const char* db, const char* key, char* buf, size_t cap,
                             size_t* len_out) {
  if (db == nullptr || key == nullptr || len_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  auto v = client_->getVariable(db, key);
  if (!v) return SKR_ERR_NOT_FOUND;
  const std::string json = flow::variantToJsonText(*v);
  *len_out = json.size() + 1;
  if (buf == nullptr || cap < json.size() + 1) return SKR_ERR_NO_MEMORY;
  std::memcpy(buf, json.c_str(), json.size() + 1);
  return SKR_OK;
}

skr_status ModuleFlow::dbRemove(const char* db, const char* key) {
  if (db == nullptr || key == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  auto r = client_->removeVariable(db, key);
  return r ? SKR_OK : fail("db_remove " + std::string(db) + " " + key, r.error());
}

skr_status ModuleFlow::dbWatch(const char* db, skr_db_change_fn fn, void* user,
                               skr_sub_handle* handle_out) {
  if (db == nullptr || fn == nullptr || handle_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  auto tell = [fn, user](const flow::PairDatabase& d, std::string_view key,
                         const flow::Variant* value) {
    const std::string k(key);
    if (value == nullptr)
      return fn(user, d.name().c_str(), key.empty() ? nullptr : k.c_str(), nullptr);
    const std::string json = flow::variantToJsonText(*value);
    fn(user, d.name().c_str(), k.c_str(), json.c_str());
  };
  auto id = client_->watchDatabase(db, tell);
  if (!id) return fail("db_watch " + std::string(db), id.error());
  const skr_sub_handle handle = next_handle_++;
  db_watches_[handle] = *id;
  *handle_out = handle;
  if (const auto pairs = client_->pairsOf(db)) {  // what it holds now
    for (const auto& [key, value] : *pairs->asMap()) {
      if (db_watches_.count(handle) == 0) break;  // unwatched from its call
      const std::string json = flow::variantToJsonText(value);
      fn(user, db, key.c_str(), json.c_str());
    }
  }
  return SKR_OK;
}

skr_status ModuleFlow::dbUnwatch(skr_sub_handle handle) {
  auto it = db_watches_.find(handle);
  if (it == db_watches_.end()) return SKR_ERR_NOT_FOUND;
  client_->unwatchDatabase(it->second);
  db_watches_.erase(it);
  return SKR_OK;
}

bool ModuleFlow::isWatching(skr_sub_handle handle) const {
  return std::any_of(channel_watches_.begin(), channel_watches_.end(),
                     [handle](const ChannelWatch& w) { return w.handle == handle; });
}

skr_status ModuleFlow::channelWatch(skr_channel_fn fn, void* user, skr_sub_handle* handle_out) {
  if (fn == nullptr || handle_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  const skr_sub_handle handle = next_handle_++;
  live(handle);
  channel_watches_.push_back(ChannelWatch{handle, fn, user});
  *handle_out = handle;
  for (const auto& ch : client_->channels()) {  // what there is now
    if (!isWatching(handle)) break;
    if (!live_) {
      fn(user, ch.id, ch.name.c_str(), static_cast<skr_channel_kind>(ch.kind), ch.mime.c_str(), 1);
      continue;
    }
    deliver(handle, [fn, user, ch] {
      fn(user, ch.id, ch.name.c_str(), static_cast<skr_channel_kind>(ch.kind), ch.mime.c_str(), 1);
    });
  }
  return SKR_OK;
}

skr_status ModuleFlow::channelUnwatch(skr_sub_handle handle) {
  auto it = std::find_if(channel_watches_.begin(), channel_watches_.end(),
                         [handle](const ChannelWatch& w) { return w.handle == handle; });
  if (it == channel_watches_.end()) return SKR_ERR_NOT_FOUND;
  gone(handle);
  channel_watches_.erase(it);
  return SKR_OK;
}

skr_status ModuleFlow::dbSync(skr_done_fn fn, void* user) {
  if (fn == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  const uint64_t id = next_sync_++;
  syncs_.emplace(id, std::make_pair(fn, user));
  client_->syncDatabases([alive = std::weak_ptr<ModuleFlow*>(alive_), id](Result<void> r) {
    const auto self = alive.lock();
    if (!self) return;  // answered BAD_STATE when the module stopped
    auto it = (*self)->syncs_.find(id);
    if (it == (*self)->syncs_.end()) return;
    const auto [done, user] = it->second;
    (*self)->syncs_.erase(it);
    if (!r) (*self)->fail("db_sync", r.error());
    done(user, r ? SKR_OK : SKR_ERR_FAILED);
  });
  return SKR_OK;
}

skr_status ModuleFlow::dbSet(const char* db, const char* key, const char* value_json) {
  if (db == nullptr || key == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  auto value = fromJson(value_json);
  if (!value) return fail("db_set", value.error());
  auto r = client_->setVariable(db, key, *value);
  return r ? SKR_OK : fail("db_set " + std::string(db) + "." + key, r.error());
}

// --- blob channels (ABI 1.4) ------------------------------------------------------------------

void ModuleFlow::BlobAnswer::operator()(skr_status status, std::string_view data,
                                        uint64_t version) const {
  const auto self = alive.lock();
  if (!self) return;  // answered BAD_STATE when the module stopped
  auto it = (*self)->blobs_.find(id);
  if (it == (*self)->blobs_.end()) return;
  const auto [fn, user] = it->second;
  (*self)->blobs_.erase(it);
  fn(user, status, data.data(), data.size(), version);
}

ModuleFlow::BlobAnswer ModuleFlow::expectBlob(skr_blob_fn fn, void* user) {
  const uint64_t id = next_blob_++;
  blobs_.emplace(id, std::make_pair(fn, user));
  return BlobAnswer{alive_, id};
}

skr_status ModuleFlow::refuseBlob(const BlobAnswer& a, const std::string& what,
                                  const Error& error) {
  blobs_.erase(a.id);
  return fail(what, error);
}

namespace {
// An error's message as a blob answer's data: NUL-terminated for C.
std::string messageOf(const Error& e) {
  return e.message + '\0';
}
}  // namespace

skr_status ModuleFlow::blobGet(uint16_t chan_id, const char* path, uint64_t max_bytes,
                               skr_blob_fn fn, void* user) {
  if (path == nullptr || fn == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  const BlobAnswer answer = expectBlob(fn, user);
  auto r =
      client_->blobGet(chan_id, path, max_bytes, [answer](Result<flow::LocalClient::BlobFile> f) {
        if (!f) return answer(toStatus(f.error().code), messageOf(f.error()), 0);
        answer(SKR_OK, f->data, f->version);
      });
  return r ? SKR_OK : refuseBlob(answer, "blob_get " + std::string(path), r.error());
}

skr_status ModuleFlow::blobPut(uint16_t chan_id, const char* path, const void* data, size_t size,
                               skr_blob_fn fn, void* user) {
  if (path == nullptr || fn == nullptr || (data == nullptr && size > 0)) {
    return SKR_ERR_INVALID_ARGUMENT;
  }
  const BlobAnswer answer = expectBlob(fn, user);
  auto r = client_->blobPut(chan_id, path,
                            std::string(static_cast<const char*>(data), data != nullptr ? size : 0),
                            [answer](Result<uint64_t> v) {
                              if (!v)
                                return answer(toStatus(v.error().code), messageOf(v.error()), 0);
                              answer(SKR_OK, {}, *v);
                            });
  return r ? SKR_OK : refuseBlob(answer, "blob_put " + std::string(path), r.error());
}

skr_status ModuleFlow::blobList(uint16_t chan_id, const char* dir, skr_blob_fn fn, void* user) {
  if (fn == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  const BlobAnswer answer = expectBlob(fn, user);
  auto r = client_->blobList(chan_id, dir != nullptr ? dir : "", [answer](Result<flow::Variant> v) {
    if (!v) return answer(toStatus(v.error().code), messageOf(v.error()), 0);
    answer(SKR_OK, flow::variantToJsonText(*v) + '\0', 0);
  });
  return r ? SKR_OK : refuseBlob(answer, "blob_list", r.error());
}

skr_status ModuleFlow::blobDo(uint16_t chan_id, skr_blob_op op, const char* path, skr_blob_fn fn,
                              void* user) {
  if (path == nullptr || fn == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  using Op = flow::LocalClient::BlobOp;
  Op what;
  switch (op) {
    case SKR_BLOB_MKDIR:
      what = Op::mkdir;
      break;
    case SKR_BLOB_RMDIR:
      what = Op::rmdir;
      break;
    case SKR_BLOB_REMOVE:
      what = Op::remove;
      break;
    default:
      return SKR_ERR_INVALID_ARGUMENT;
  }
  const BlobAnswer answer = expectBlob(fn, user);
  auto r = client_->blobDo(chan_id, what, path, [answer](Result<void> v) {
    if (!v) return answer(toStatus(v.error().code), messageOf(v.error()), 0);
    answer(SKR_OK, {}, 0);
  });
  return r ? SKR_OK : refuseBlob(answer, "blob_do " + std::string(path), r.error());
}

// --- the sync pulse (ABI 1.5) ---------------------------------------------------------------

skr_status ModuleFlow::syncPulse(uint16_t chan_id) {
  auto r = client_->pulse(chan_id);
  return r ? SKR_OK : fail("sync_pulse", r.error());
}

skr_status ModuleFlow::syncFollow(const char* name, uint32_t every, uint32_t flags, skr_sync_fn fn,
                                  void* user, skr_sub_handle* handle_out) {
  if (name == nullptr || fn == nullptr || handle_out == nullptr) return SKR_ERR_INVALID_ARGUMENT;
  const std::string n = name;
  if (std::any_of(follows_.begin(), follows_.end(), [&](const Follow& f) { return f.name == n; })) {
    return fail("sync_follow " + n, makeError(Errc::invalid_argument, "it follows it already"));
  }
  if (auto r = client_->follow(n, every); !r) return fail("sync_follow " + n, r.error());
  *handle_out = next_handle_++;
  follows_.push_back(Follow{*handle_out, n, client_->findChannel(n).value_or(0), flags, fn, user});
  return SKR_OK;
}

skr_status ModuleFlow::syncUnfollow(skr_sub_handle handle) {
  auto it = std::find_if(follows_.begin(), follows_.end(),
                         [handle](const Follow& f) { return f.handle == handle; });
  if (it == follows_.end()) return SKR_ERR_NOT_FOUND;
  client_->unfollow(it->name);
  follows_.erase(it);
  return SKR_OK;
}

skr_status ModuleFlow::syncDone(skr_sub_handle handle, uint64_t seq) {
  auto it = std::find_if(follows_.begin(), follows_.end(),
                         [handle](const Follow& f) { return f.handle == handle; });
  if (it == follows_.end()) return SKR_ERR_NOT_FOUND;
  if (it->chan_id != 0) client_->syncDone(it->chan_id, seq);
  return SKR_OK;
}

}  // namespace skr
