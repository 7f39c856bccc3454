// SPDX-License-Identifier: Apache-2.0
// Events on the flow: the channel table, subscriptions by name, data, services, errors. A frame
// that breaks the protocol closes the connection (SAT-PROTOCOL) and the satellite reconnects.
#include <skrobot/core/log.h>

#include <algorithm>

#include "satellite_impl.h"

namespace skr::sat {

namespace msg = flow::msg;
using flow::Code;

// Decodes `body` as M into `var`, or drops the connection as the hub broke the protocol.
// NOLINTBEGIN(bugprone-macro-parentheses): `M` is a type
#define SAT_DECODE(M, var)                      \
  auto var##_r = flow::decode<M>(body, limits); \
  if (!var##_r) {                               \
    drop(var##_r.error().message, true);        \
    return;                                     \
  }                                             \
  auto& var = var##_r.value();
// NOLINTEND(bugprone-macro-parentheses)

void Satellite::Impl::event(uint8_t code, std::string_view body) {
  const flow::DecodeLimits limits{32, opt.connection.max_frame_bytes};
  const uint64_t gen = generation;
  switch (static_cast<Code>(code)) {
    case Code::ev_data: {
      SAT_DECODE(msg::EvData, m);
      self.dataView.emit(m.chan_id, m.payload.bytes);
      if (gen == generation && self.data.connectionCount() > 0) {
        self.data.emit(m.chan_id, std::string(m.payload.bytes));
      }
      return;
    }
    case Code::ev_chan_added: {
      SAT_DECODE(msg::EvChanAdded, m);
      onChanAdded(m);
      return;
    }
    case Code::ev_chan_removed: {
      SAT_DECODE(msg::EvChanRemoved, m);
      onChanRemoved(m);
      return;
    }
    case Code::ev_sync_pulse: {
      SAT_DECODE(msg::EvSyncPulse, m);
      const SyncPulse p{m.chan_id, m.seq, m.source_time_ns, m.dropped, monotonicNs()};
      self.syncPulse.emit(p);
      // The slots' work is the tick this pulse drove: done now.
      if (gen == generation && flowOpen()) send(msg::SyncDone{m.chan_id, m.seq});
      return;
    }
    case Code::ev_link_wanted: {
      SAT_DECODE(msg::EvLinkWanted, m);
      self.linkWanted.emit(m.hub_name);
      return;
    }
    case Code::ev_time_probe: {
      SAT_DECODE(msg::EvTimeProbe, m);
      const TimeSample t{m.tag, static_cast<int64_t>(m.t1), static_cast<int64_t>(m.t2),
                         static_cast<int64_t>(m.t3), realtimeNs()};
      self.timeSample.emit(t);
      return;
    }
    case Code::ev_chan_header: {
      SAT_DECODE(msg::EvChanHeader, m);
      upsert(m.info);
      self.channelChanged.emit(m.info);
      return;
    }
    case Code::ev_start_publish:
    case Code::ev_stop_publish: {
      SAT_DECODE(msg::EvStartPublish, m);  // both are a u16 channel id
      const bool start = static_cast<Code>(code) == Code::ev_start_publish;
      for (auto& [name, o] : own) {
        if (o.id == m.chan_id && o.id != 0) o.subscribers = start;
      }
      if (start) {
        self.startPublish.emit(m.chan_id);
      } else {
        self.stopPublish.emit(m.chan_id);
      }
      return;
    }
    case Code::ev_service_request: {
      SAT_DECODE(msg::EvServiceRequest, m);
      self.serviceRequest.emit(m);
      return;
    }
    case Code::ev_service_response: {
      SAT_DECODE(msg::EvServiceResponse, m);
      Response r{m.chan_id, m.tag, static_cast<flow::ErrorCode>(m.error), std::move(m.value)};
      ResponseHandler handler;
      if (auto it = pending.find(m.tag); it != pending.end()) {
        handler = std::move(it->second);
        pending.erase(it);
      }
      if (handler) handler(r);
      if (gen == generation) self.serviceResponse.emit(r);
      return;
    }
    case Code::ev_error: {
      SAT_DECODE(msg::EvError, m);
      if (m.command == uint8_t(Code::phys_request) && paths->onRefused(m)) return;
      onHubError(m);
      return;
    }
    case Code::ev_phys_grant: {
      SAT_DECODE(msg::EvPhysGrant, m);
      paths->onGrant(m);
      return;
    }
    case Code::ev_phys_path: {
      SAT_DECODE(msg::EvPhysPath, m);
      paths->onPath(m);
      return;
    }
    case Code::ev_phys_revoke: {
      SAT_DECODE(msg::EvPhysRevoke, m);
      paths->onRevoke(m);
      return;
    }
    case Code::ev_phys_relay: {
      SAT_DECODE(msg::EvPhysRelay, m);
      paths->onRelay(m);
      return;
    }
    case Code::ev_phys_switch: {
      SAT_DECODE(msg::EvPhysSwitch, m);
      paths->onSwitch(m);
      return;
    }
    case Code::ev_phys_resume: {
      SAT_DECODE(msg::EvPhysResume, m);
      paths->onResume(m);
      return;
    }
    case Code::ev_phys_marker: {
      SAT_DECODE(msg::EvPhysMarker, m);
      paths->onMarker(m);
      return;
    }
    case Code::ev_db_changed: {
      SAT_DECODE(msg::EvDbChanged, m);  // flow_db follows what we asked, in flow order
      (void)m;
      return;
    }
    case Code::ev_db_value: {
      SAT_DECODE(msg::EvDbValue, m);
      if (auto it = reads.find(m.tag); it != reads.end()) {
        ResponseHandler handler = std::move(it->second);
        reads.erase(it);
        if (handler) handler(Response{0, m.tag, flow::ErrorCode::ok, std::move(m.value)});
      }
      return;
    }
    case Code::ev_db_synced: {
      SAT_DECODE(msg::EvDbSynced, m);
      self.databasesSynced.emit(m.tag);
      return;
    }
    case Code::ev_blob_changed: {
      SAT_DECODE(msg::EvBlobChanged, m);
      self.blobChanged.emit(BlobChange{m.chan_id, static_cast<msg::BlobChange>(m.change),
                                       std::move(m.path), m.size, m.version});
      return;
    }
    case Code::ev_dropped: {
      SAT_DECODE(msg::EvDropped, m);
      stats.data_dropped += m.count;
      const Nanos now = monotonicNs();
      if (now - last_drop_log_ns > kNsPerSec) {
        last_drop_log_ns = now;
        log::warn(kLogSource, "SAT-DROPPED",
                  "the hub dropped " + std::to_string(m.count) + " data frames of channel " +
                      std::to_string(m.chan_id) + ": this satellite reads too slowly");
      }
      return;
    }
    default: {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02x", code);
      drop("the hub sent " + std::string(flow::codeName(code)) + " (" + hex + ") on a flow", true);
      return;
    }
  }
}

#undef SAT_DECODE

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
      paths->serve(ev.info.id, ev.info.name, mine->spec.physical);
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
