// SPDX-License-Identifier: Apache-2.0
// Events on the flow: the channel table, subscriptions by name, data, services, errors. A frame
// that breaks the protocol closes the connection (SAT-PROTOCOL) and the satellite reconnects.
#include <skrobot/runtime/log.h>

#include <algorithm>

#include "satellite_impl.h"

#include <skrobot/runtime/flow/event_dispatch.h>

namespace skr::sat {

namespace msg = flow::msg;
using flow::Code;

namespace {

// The events of a flow, one overload per event row of the catalogue (flow::dispatchEvent calls
// them; a new event row without one does not compile). `gen` is the connection the event came on:
// a slot may reconnect, and what follows a slot is skipped then.
struct Events {
  Satellite::Impl& s;
  const uint64_t gen = s.generation;

  [[nodiscard]] bool same() const { return gen == s.generation; }

  void on(msg::EvData& m) {
    s.self.dataView.emit(m.chan_id, m.payload.bytes);
    if (same() && s.self.data.connectionCount() > 0) {
      s.self.data.emit(m.chan_id, std::string(m.payload.bytes));
    }
  }
  void on(msg::EvChanAdded& m) { s.onChanAdded(m); }
  void on(msg::EvChanRemoved& m) { s.onChanRemoved(m); }
  void on(msg::EvSyncPulse& m) {
    const SyncPulse p{m.chan_id, m.seq, m.source_time_ns, m.dropped, monotonicNs()};
    s.self.syncPulse.emit(p);
    // The slots' work is the tick this pulse drove: done now.
    if (same() && s.flowOpen()) s.send(msg::SyncDone{m.chan_id, m.seq});
  }
  void on(msg::EvLinkWanted& m) { s.self.linkWanted.emit(m.hub_name); }
  void on(msg::EvTimeProbe& m) {
    const TimeSample t{m.tag, static_cast<int64_t>(m.t1), static_cast<int64_t>(m.t2),
                       static_cast<int64_t>(m.t3), realtimeNs()};
    s.self.timeSample.emit(t);
  }
  void on(msg::EvChanHeader& m) {
    s.upsert(m.info);
    s.self.channelChanged.emit(m.info);
  }
  void on(msg::EvStartPublish& m) { publishing(m.chan_id, true); }
  void on(msg::EvStopPublish& m) { publishing(m.chan_id, false); }
  void publishing(uint16_t chan_id, bool start) {
    for (auto& [name, o] : s.own) {
      if (o.id == chan_id && o.id != 0) o.subscribers = start;
    }
    if (start) {
      s.self.startPublish.emit(chan_id);
    } else {
      s.self.stopPublish.emit(chan_id);
    }
  }
  void on(msg::EvServiceRequest& m) { s.self.serviceRequest.emit(m); }
  void on(msg::EvServiceResponse& m) {
    Response r{m.chan_id, m.tag, static_cast<flow::ErrorCode>(m.error), std::move(m.value)};
    Satellite::ResponseHandler handler;
    if (auto it = s.pending.find(m.tag); it != s.pending.end()) {
      handler = std::move(it->second);
      s.pending.erase(it);
    }
    if (handler) handler(r);
    if (same()) s.self.serviceResponse.emit(r);
  }
  void on(msg::EvError& m) {
    if (m.command == uint8_t(Code::phys_request) && s.paths->onRefused(m)) return;
    s.onHubError(m);
  }
  void on(msg::EvPhysGrant& m) { s.paths->onGrant(m); }
  void on(msg::EvPhysPath& m) { s.paths->onPath(m); }
  void on(msg::EvPhysRevoke& m) { s.paths->onRevoke(m); }
  void on(msg::EvPhysRelay& m) { s.paths->onRelay(m); }
  void on(msg::EvPhysSwitch& m) { s.paths->onSwitch(m); }
  void on(msg::EvPhysResume& m) { s.paths->onResume(m); }
  void on(msg::EvPhysMarker& m) { s.paths->onMarker(m); }
  void on(msg::EvDbChanged& /*m*/) {}  // flow_db follows what we asked, in flow order
  void on(msg::EvDbValue& m) {
    if (auto it = s.reads.find(m.tag); it != s.reads.end()) {
      Satellite::ResponseHandler handler = std::move(it->second);
      s.reads.erase(it);
      if (handler) handler(Response{0, m.tag, flow::ErrorCode::ok, std::move(m.value)});
    }
  }
  void on(msg::EvDbSynced& m) { s.self.databasesSynced.emit(m.tag); }
  void on(msg::EvBlobChanged& m) {
    s.self.blobChanged.emit(BlobChange{m.chan_id, static_cast<msg::BlobChange>(m.change),
                                       std::move(m.path), m.size, m.version});
  }
  void on(msg::EvDropped& m) {
    s.stats.data_dropped += m.count;
    const Nanos now = monotonicNs();
    if (now - s.last_drop_log_ns > kNsPerSec) {
      s.last_drop_log_ns = now;
      log::warn(kLogSource, "SAT-DROPPED",
                "the hub dropped " + std::to_string(m.count) + " data frames of channel " +
                    std::to_string(m.chan_id) + ": this satellite reads too slowly");
    }
  }
  // A frame that breaks the protocol: the satellite drops the connection and reconnects.
  void broken(const std::string& why) { s.drop(why, true); }
  void unexpected(uint8_t code) {
    char hex[8];
    std::snprintf(hex, sizeof hex, "0x%02x", code);
    s.drop("the hub sent " + std::string(flow::codeName(code)) + " (" + hex + ") on a flow", true);
  }
};

}  // namespace

void Satellite::Impl::event(uint8_t code, std::string_view body) {
  Events events{*this};
  flow::dispatchEvent(events, code, body, flow::DecodeLimits{32, opt.connection.max_frame_bytes});
}

void Satellite::Impl::upsert(const ChannelInfo& info) {
  if (auto old = table.find(info.id); old != table.end() && old->second.name != info.name) {
    by_name.erase(old->second.name);
  }
  table[info.id] = info;
  by_name[info.name] = info.id;
}

void Satellite::Impl::onChanAdded(msg::EvChanAdded& ev) {
  const uint64_t gen = generation;
  upsert(ev.info);
  Own* mine = nullptr;
  if (ev.tag != 0) {
    for (auto& [name, o] : own) {
      if (o.tag == ev.tag) mine = &o;
    }
  }
  if (auto orphan = std::find(orphan_tags.begin(), orphan_tags.end(), ev.tag);
      ev.tag != 0 && orphan != orphan_tags.end()) {
    orphan_tags.erase(orphan);
    send(msg::ChanRemove{nextTag(), ev.info.id});
  }
  if (mine != nullptr) {
    mine->id = ev.info.id;
    mine->tag = 0;
    mine->retries = 0;
    if (mine->spec.kind == flow::ChannelKind::streaming && login.minor >= 7) {
      const PhysicalOptions& o = mine->spec.physical;
      paths->serve(ev.info.id, ev.info.name,
                   uint8_t((o.direct ? msg::kPhysDirect : 0) | (o.shm ? msg::kPhysShm : 0)),
                   o.ring);
    }
    log::debug(kLogSource, "SAT-CHANNEL",
               "channel " + ev.info.name + " is ready (id " + std::to_string(ev.info.id) + ")");
  }
  self.channelAdded.emit(ev.info);
  if (gen != generation) return;
  if (mine != nullptr) {
    self.channelReady.emit(ev.info);
    if (gen != generation) return;
  }
  if (auto it = subs.find(ev.info.name); it != subs.end() && it->second == 0) {
    attach(ev.info.name, ev.info.id);
  }
}

void Satellite::Impl::onChanRemoved(const msg::EvChanRemoved& ev) {
  auto it = table.find(ev.chan_id);
  if (it == table.end() || it->second.hash != ev.hash) return;  // not the instance we know
  const ChannelInfo info = std::move(it->second);
  paths->onUnsubscribed(ev.chan_id);
  table.erase(it);
  if (auto n = by_name.find(info.name); n != by_name.end() && n->second == info.id) {
    by_name.erase(n);
  }
  for (auto& [name, o] : own) {
    if (o.id == info.id) o.id = 0, o.subscribers = false;
  }
  if (auto s = subs.find(info.name); s != subs.end() && s->second == info.id) s->second = 0;
  self.channelRemoved.emit(info);
}

void Satellite::Impl::onHubError(const msg::EvError& ev) {
  const auto command = static_cast<Code>(ev.command);
  if (command == Code::db_read) {  // the reader's handler hears of it
    if (auto it = reads.find(ev.tag); it != reads.end()) {
      ResponseHandler handler = std::move(it->second);
      reads.erase(it);
      if (handler) {
        handler(Response{ev.chan_id, ev.tag, static_cast<flow::ErrorCode>(ev.error),
                         flow::Variant(ev.message)});
      }
      return;
    }
  }
  if (command == Code::subscribe_queue &&
      static_cast<flow::ErrorCode>(ev.error) == flow::ErrorCode::limit_exceeded) {
    // Subscribed all the same, with the hub's cap as our queue.
    log::warn(kLogSource, "SAT-QUEUE-CLAMPED", ev.message);
    self.error.emit(ev);
    return;
  }
  std::string what = std::string(flow::codeName(ev.command));
  if (command == Code::chan_add && ev.tag != 0) {
    for (auto& [name, o] : own) {
      if (o.tag != ev.tag) continue;
      o.tag = 0;
      ++o.retries;  // an old copy of it may still be going away: onOneSecond() asks again
      what += " " + name;
    }
  }
  log::warn(kLogSource, "SAT-HUB-ERROR",
            "the hub refused " + what + ": " +
                std::string(flow::errorCodeName(static_cast<flow::ErrorCode>(ev.error))) + ": " +
                ev.message);
  self.error.emit(ev);
}

void Satellite::Impl::attach(const std::string& name, uint16_t id) {
  subs[name] = id;
  if (auto f = follows.find(name); f != follows.end()) {
    send(msg::SyncFollow{nextTag(), id, f->second});
  } else if (auto q = queues.find(name); q != queues.end() && login.minor >= 13) {
    send(msg::SubscribeQueue{nextTag(), id, q->second});
  } else {
    send(msg::Subscribe{nextTag(), id});
  }
  if (login.minor >= 7) paths->onSubscribed(name, id);
  if (auto it = table.find(id); it != table.end()) {
    const ChannelInfo info = it->second;
    self.subscribed.emit(info);
  }
}

void Satellite::Impl::sendChanAdd(Own& o) {
  o.tag = nextTag();
  send(msg::ChanAdd{o.tag, static_cast<uint8_t>(o.spec.kind), o.spec.name, o.spec.mime,
                    o.spec.props});
}

}  // namespace skr::sat
