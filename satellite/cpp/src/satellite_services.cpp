// SPDX-License-Identifier: Apache-2.0
// Satellite: service requests and answers, and PairDatabase access (blocking reads over the
// synchronous connection, writes on the flow).
#include "satellite_impl.h"

namespace skr::sat {

namespace msg = flow::msg;
using flow::Variant;

namespace {
Error notConnected() {
  return makeError(Errc::closed, "not connected to the hub");
}
}  // namespace

Result<uint32_t> Satellite::request(std::string_view service, const std::string& command,
                                    const Variant& value, ResponseHandler done,
                                    uint32_t timeout_ms) {
  if (!impl_->flowOpen()) return notConnected();
  auto id = channelId(service);
  if (!id) return makeError(Errc::not_found, "no channel " + std::string(service));
  return request(*id, command, value, std::move(done), timeout_ms);
}

Result<uint32_t> Satellite::request(uint16_t chan_id, const std::string& command,
                                    const Variant& value, ResponseHandler done,
                                    uint32_t timeout_ms) {
  if (!impl_->flowOpen()) return notConnected();
  if (timeout_ms != 0) {
    if (auto r = impl_->needs(flow::Code::service_request_timed, "does not time requests out");
        !r) {
      return r.error();
    }
  }
  const uint32_t tag = impl_->nextTag();
  impl_->pending[tag] = std::move(done);
  if (timeout_ms == 0) {
    impl_->send(msg::ServiceRequest{tag, chan_id, command, value});
  } else {
    impl_->send(msg::ServiceRequestTimed{tag, chan_id, timeout_ms, command, value});
  }
  return tag;
}

Result<void> Satellite::respond(const Request& request, const Variant& value) {
  if (!impl_->flowOpen()) return notConnected();
  impl_->send(msg::ServiceResponse{request.chan_id, request.request, value});
  return {};
}

Result<SyncClient*> Satellite::Impl::syncClient() {
  if (sync && sync->isOpen()) return &*sync;
  ConnectOptions o = opt.connection;
  o.client_name = (o.client_name.empty() ? "satellite" : o.client_name) + "/sync";
  auto c = SyncClient::connect(o);
  if (!c) return c.error();
  sync = std::move(c).value();
  return &*sync;
}

Result<SyncClient*> Satellite::syncClient() {
  return impl_->syncClient();
}

Result<Variant> Satellite::call(std::string_view service, const std::string& command,
                                const Variant& value, uint32_t timeout_ms) {
  const std::string name(service);
  const auto known = channelId(name);
  return impl_->withSync([&](SyncClient& c) -> Result<Variant> {
    if (known) return c.call(*known, command, value, timeout_ms);
    return c.call(name, command, value, timeout_ms);
  });
}

Result<Variant> Satellite::get(const std::string& key, const std::string& db) {
  return impl_->withSync([&](SyncClient& c) -> Result<Variant> {
    if (auto s = c.selectDatabase(db.empty() ? c.login().user : db); !s) return s.error();
    return c.get(key);
  });
}

Result<Variant::Map> Satellite::getAll(const std::string& db) {
  return impl_->withSync([&](SyncClient& c) -> Result<Variant::Map> {
    if (auto s = c.selectDatabase(db.empty() ? c.login().user : db); !s) return s.error();
    return c.getAll();
  });
}

Result<std::vector<std::string>> Satellite::keys(const std::string& db) {
  return impl_->withSync([&](SyncClient& c) -> Result<std::vector<std::string>> {
    if (auto s = c.selectDatabase(db.empty() ? c.login().user : db); !s) return s.error();
    return c.keys();
  });
}

// Writes to another database than the flow's current one switch to it and back, in order.
Result<uint32_t> Satellite::set(const std::string& key, const Variant& value,
                                const std::string& db) {
  if (!impl_->flowOpen()) return notConnected();
  const std::string back = impl_->flow_db;
  const bool other = !db.empty() && db != back;
  if (other) impl_->send(msg::DbSetCurrent{impl_->nextTag(), db});
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::VarSetAsync{tag, key, value});
  if (other) impl_->send(msg::DbSetCurrent{impl_->nextTag(), back});
  return tag;
}

Result<uint32_t> Satellite::del(const std::string& key, const std::string& db) {
  if (!impl_->flowOpen()) return notConnected();
  const std::string back = impl_->flow_db;
  const bool other = !db.empty() && db != back;
  if (other) impl_->send(msg::DbSetCurrent{impl_->nextTag(), db});
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::VarDelAsync{tag, key});
  if (other) impl_->send(msg::DbSetCurrent{impl_->nextTag(), back});
  return tag;
}

Result<uint32_t> Satellite::createDatabase(const std::string& name) {
  if (!impl_->flowOpen()) return notConnected();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::DbCreateAsync{tag, name});
  return tag;
}

Result<uint32_t> Satellite::saveDatabase(const std::string& name) {
  if (!impl_->flowOpen()) return notConnected();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::DbSaveAsync{tag, name});
  return tag;
}

Result<uint32_t> Satellite::syncDatabases() {
  if (!impl_->flowOpen()) return notConnected();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::DbSyncAsync{tag});
  return tag;
}

Result<uint32_t> Satellite::replicate(std::string source, std::string short_name) {
  if (!impl_->flowOpen()) return notConnected();
  if (auto r = impl_->needs(flow::Code::replicate_channel, "has no replicas"); !r) return r.error();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::ReplicateChannel{tag, source, short_name});
  impl_->replicas[std::move(short_name)] = std::move(source);
  return tag;
}

Result<uint32_t> Satellite::stopReplica(std::string_view short_name) {
  auto it = impl_->replicas.find(short_name);
  if (it == impl_->replicas.end()) return makeError(Errc::not_found, "no such replica of ours");
  impl_->replicas.erase(it);
  if (!impl_->flowOpen()) return notConnected();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::ReplicateStop{tag, std::string(short_name)});
  return tag;
}

Result<uint32_t> Satellite::readDatabase(const std::string& db, msg::DbReadWhat what,
                                         const std::string& key, ResponseHandler done) {
  if (!impl_->flowOpen()) return notConnected();
  if (auto r = impl_->needs(flow::Code::db_read, "has no database reads on a flow"); !r) {
    return r.error();
  }
  const uint32_t tag = impl_->nextTag();
  impl_->reads[tag] = std::move(done);
  impl_->send(msg::DbRead{tag, db, static_cast<uint8_t>(what), key});
  return tag;
}

Result<uint32_t> Satellite::offerChannel(const ChannelInfo& channel) {
  if (!impl_->flowOpen()) return notConnected();
  if (auto r = impl_->needs(flow::Code::link_offer, "shares no hub link"); !r) return r.error();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::LinkOffer{tag, channel.kind, channel.name, channel.mime, channel.props});
  return tag;
}

Result<void> Satellite::withdrawChannel(uint16_t chan_id) {
  if (!impl_->flowOpen()) return notConnected();
  impl_->send(msg::ChanRemove{impl_->nextTag(), chan_id});
  return {};
}

Result<void> Satellite::setChannelProperties(uint16_t chan_id, Variant::Map props) {
  if (!impl_->flowOpen()) return notConnected();
  impl_->send(msg::ChanSetProps{impl_->nextTag(), chan_id, Variant(std::move(props))});
  return {};
}

Result<uint32_t> Satellite::probeTime() {
  if (!impl_->flowOpen()) return notConnected();
  if (auto r = impl_->needs(flow::Code::time_probe, "has no clock probe"); !r) return r.error();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::TimeProbe{tag, static_cast<uint64_t>(realtimeNs())});
  return tag;
}

Result<uint32_t> Satellite::selectDatabase(const std::string& name) {
  impl_->wanted_db = name;
  if (!impl_->flowOpen()) return notConnected();
  const uint32_t tag = impl_->nextTag();
  impl_->send(msg::DbSetCurrent{tag, name});
  impl_->flow_db = name;
  return tag;
}

}  // namespace skr::sat
