// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/satellite/sync_client.h>

#include <unistd.h>

#include <algorithm>

#include "in_buffer.h"
#include "posix_socket.h"

namespace skr::sat {

namespace msg = flow::msg;
using flow::Code;
using flow::ErrorCode;
using flow::Variant;

SyncClient::SyncClient(int fd, ConnectOptions options) : fd_(fd), options_(std::move(options)) {}

SyncClient::~SyncClient() {
  close();
}

SyncClient::SyncClient(SyncClient&& o) noexcept
    : fd_(o.fd_),
      tls_(std::move(o.tls_)),
      options_(std::move(o.options_)),
      login_(std::move(o.login_)),
      last_error_(o.last_error_),
      in_(std::move(o.in_)) {
  o.fd_ = -1;
}

SyncClient& SyncClient::operator=(SyncClient&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    o.fd_ = -1;
    tls_ = std::move(o.tls_);
    options_ = std::move(o.options_);
    login_ = std::move(o.login_);
    last_error_ = o.last_error_;
    in_ = std::move(o.in_);
  }
  return *this;
}

void SyncClient::close() noexcept {
  if (fd_ >= 0 && tls_) detail::closeTls(fd_, *tls_);
  tls_.reset();
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  in_.reset();
}

Error SyncClient::fail(Errc code, std::string message) {
  if (code == Errc::closed || code == Errc::protocol_error || code == Errc::timeout) close();
  return makeError(code, std::move(message));
}

Result<SyncClient> SyncClient::connect(const ConnectOptions& options) {
  auto fd = detail::connectSocket(options.address, options.timeout_ms);
  if (!fd) return fd.error();
  SyncClient c(*fd, options);
  if (options.address.kind == Address::Kind::tls) {
    auto ctx = flow::TlsContext::create(flow::TlsRole::client, options.tls);
    if (!ctx) return ctx.error();
    auto session = detail::tlsHandshake(*fd, *ctx, options.address, options.timeout_ms);
    if (!session) return session.error();
    c.tls_.emplace(std::move(session).value());
  }
  msg::Login m;
  m.user = options.user;
  m.password = options.password;
  m.client_name = options.client_name.empty() ? "sync" : options.client_name;
  auto r = c.request(m, options.timeout_ms);
  if (!r) {
    // With TLS 1.3 a hub that refuses our certificate says so after the handshake: here.
    if (c.tls_ || options.address.kind == Address::Kind::tls) {
      return makeError(Errc::io_error,
                       "TLS with " + options.address.toString() + ": " + r.error().message);
    }
    return r.error();
  }
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) {
    const Errc e = flow::toErrc(c.last_error_);  // auth_failed, version_mismatch, ...
    auto err = flow::decode<msg::ReplyError>(r->body);
    return makeError(e, "login to " + options.address.toString() + " as \"" + options.user +
                            "\" refused: " + (err ? err->message : "?"));
  }
  auto ok = flow::decode<msg::LoginOk>(r->body);
  if (!ok) return c.fail(Errc::protocol_error, "LOGIN reply: " + ok.error().message);
  c.login_ = std::move(ok).value();
  return c;
}

Result<SyncClient::Reply> SyncClient::roundTrip(const std::string& frame, uint32_t timeout_ms) {
  if (auto s = sendFrame(frame); !s) return s.error();
  return receiveReply(timeout_ms);
}

Result<void> SyncClient::sendFrame(std::string_view frame, std::string_view more) {
  if (fd_ < 0) return makeError(Errc::closed, "the synchronous connection is closed");
  if (auto s = detail::sendAll(fd_, tls_ ? &*tls_ : nullptr, frame, more); !s)
    return fail(s.error().code, s.error().message);
  return {};
}

Result<SyncClient::Reply> SyncClient::receiveReply(uint32_t timeout_ms) {
  auto v = receiveView(timeout_ms);
  if (!v) return v.error();
  return Reply{v->code, std::string(v->body)};
}

Result<SyncClient::ReplyView> SyncClient::receiveView(uint32_t timeout_ms) {
  if (fd_ < 0) return makeError(Errc::closed, "the synchronous connection is closed");
  if (!in_) in_ = std::make_unique<flow::InBuffer>();
  last_error_ = ErrorCode::ok;
  const flow::FrameSplitter splitter(options_.max_frame_bytes);
  for (;;) {
    const std::string_view have = in_->view();
    const auto n = splitter.next(reinterpret_cast<const uint8_t*>(have.data()), have.size());
    if (n.status == flow::FrameSplitter::Status::frame) {
      in_->consume(n.consumed);  // the view stays valid: bytes move only in the next receive
      const ReplyView reply{n.code, n.body};
      if (reply.code == static_cast<uint8_t>(Code::reply_error)) {
        auto e = flow::decode<msg::ReplyError>(reply.body);
        if (!e) return fail(Errc::protocol_error, "REPLY_ERROR: " + e.error().message);
        last_error_ = static_cast<ErrorCode>(e->error);
        if (last_error_ == ErrorCode::ok) last_error_ = ErrorCode::internal;
      } else if (reply.code != static_cast<uint8_t>(Code::reply_ok)) {
        return fail(Errc::protocol_error, "the hub sent " +
                                              std::string(flow::codeName(reply.code)) +
                                              " on a synchronous connection");
      }
      return reply;
    }
    if (n.status != flow::FrameSplitter::Status::need_more) {
      return fail(Errc::protocol_error,
                  "bad frame length " + std::to_string(n.announced) + " from the hub");
    }
    // Room for the rest of the frame (its length was checked), read into without a copy.
    constexpr size_t kReadChunk = 64 << 10;
    const size_t room = std::max(kReadChunk, n.wanted > have.size() ? n.wanted - have.size() : 0);
    auto r = detail::readSome(fd_, tls_ ? &*tls_ : nullptr, in_->tail(room), room, timeout_ms);
    if (!r) return fail(r.error().code, r.error().message);
    in_->commit(*r);
  }
}

Error SyncClient::hubError(ErrorCode code, const std::string& body) {
  auto e = flow::decode<msg::ReplyError>(body);
  return makeError(toErrc(code), e ? e->message : std::string(flow::errorCodeName(code)));
}

Result<void> SyncClient::expectEmpty(Result<Reply> r) {
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
  if (!r->body.empty()) return fail(Errc::protocol_error, "REPLY_OK has unexpected bytes");
  return {};
}

Result<Variant> SyncClient::expectValue(Result<Reply> r) {
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
  auto v = flow::decode<msg::ReplyValue>(r->body);
  if (!v) return fail(Errc::protocol_error, v.error().message);
  return std::move(v->value);
}

namespace {
Result<std::vector<std::string>> stringList(Result<Variant> v) {
  if (!v) return v.error();
  std::vector<std::string> out;
  const auto* list = v->asList();
  if (list == nullptr) return makeError(Errc::protocol_error, "expected a list of names");
  for (const auto& item : *list) {
    if (!item.isString()) return makeError(Errc::protocol_error, "expected a list of names");
    out.push_back(*item.asString());
  }
  return out;
}
}  // namespace

Result<void> SyncClient::selectDatabase(const std::string& name) {
  return expectEmpty(request(msg::DbSelect{name}, options_.timeout_ms));
}
Result<void> SyncClient::createDatabase(const std::string& name) {
  return expectEmpty(request(msg::DbCreate{name}, options_.timeout_ms));
}
Result<void> SyncClient::saveDatabase(const std::string& name) {
  return expectEmpty(request(msg::DbSave{name}, options_.timeout_ms));
}
Result<void> SyncClient::syncDatabases() {
  return expectEmpty(request(msg::Empty<Code::db_sync>{}, options_.timeout_ms));
}
Result<void> SyncClient::removeDatabase(const std::string& name) {
  return expectEmpty(request(msg::DbRemove{name}, options_.timeout_ms));
}
Result<std::vector<std::string>> SyncClient::databases() {
  return stringList(expectValue(request(msg::Empty<Code::db_list>{}, options_.timeout_ms)));
}
Result<Variant> SyncClient::get(const std::string& key) {
  return expectValue(request(msg::VarGet{key}, options_.timeout_ms));
}
Result<void> SyncClient::set(const std::string& key, const Variant& value) {
  return expectEmpty(request(msg::VarSet{key, value}, options_.timeout_ms));
}
Result<void> SyncClient::del(const std::string& key) {
  return expectEmpty(request(msg::VarDel{key}, options_.timeout_ms));
}
Result<Variant::Map> SyncClient::getAll() {
  auto v = expectValue(request(msg::Empty<Code::var_get_all>{}, options_.timeout_ms));
  if (!v) return v.error();
  if (!v->isMap()) return fail(Errc::protocol_error, "VAR_GET_ALL: expected a map");
  return std::move(*v->asMap());
}
Result<std::vector<std::string>> SyncClient::keys() {
  return stringList(expectValue(request(msg::Empty<Code::var_keys>{}, options_.timeout_ms)));
}

Result<std::vector<ChannelInfo>> SyncClient::channels() {
  auto r = request(msg::Empty<Code::chan_list>{}, options_.timeout_ms);
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
  auto list = flow::decode<msg::ChannelList>(r->body);
  if (!list) return fail(Errc::protocol_error, list.error().message);
  return std::move(list->channels);
}

Result<ChannelInfo> SyncClient::channel(const std::string& name) {
  auto r = request(msg::ChanInfoByName{name}, options_.timeout_ms);
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
  auto info = flow::decode<msg::ChannelInfoReply>(r->body);
  if (!info) return fail(Errc::protocol_error, info.error().message);
  return std::move(info->info);
}

Result<Variant> SyncClient::call(uint16_t chan_id, const std::string& command, const Variant& value,
                                 uint32_t timeout_ms) {
  // The hub answers `timeout` itself; our own limit only guards against a hub that hangs.
  const uint32_t wait_ms = (timeout_ms == 0 ? 10000 : timeout_ms) + options_.timeout_ms;
  return expectValue(request(msg::ServiceCall{chan_id, timeout_ms, command, value}, wait_ms));
}

Result<Variant> SyncClient::call(const std::string& service, const std::string& command,
                                 const Variant& value, uint32_t timeout_ms) {
  auto info = channel(service);
  if (!info) return info.error();
  return call(info->id, command, value, timeout_ms);
}

Result<flow::Variant> SyncClient::admin(const std::string& command, const flow::Variant& args) {
  return expectValue(request(msg::Admin{command, args}, options_.timeout_ms));
}

Result<void> SyncClient::pollRegister(uint16_t chan_id) {
  return expectEmpty(request(msg::PollRegister{chan_id}, options_.timeout_ms));
}

Result<SyncClient::Polled> SyncClient::pollFetch(uint16_t chan_id) {
  auto r = request(msg::PollFetch{chan_id}, options_.timeout_ms);
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok)) return hubError(last_error_, r->body);
  auto data = flow::decode<msg::PollData>(r->body);
  if (!data) return fail(Errc::protocol_error, data.error().message);
  return Polled{data->seq, std::string(data->payload.bytes)};
}

Result<void> SyncClient::pollDeregister(uint16_t chan_id) {
  const uint16_t needs = flow::minorOf(Code::poll_deregister);
  if (login_.minor < needs) {
    return makeError(Errc::unsupported, "this hub (FlowProtocol 1." + std::to_string(login_.minor) +
                                            ") has no POLL_DEREGISTER: it needs 1." +
                                            std::to_string(needs));
  }
  return expectEmpty(request(msg::PollDeregister{chan_id}, options_.timeout_ms));
}

Result<void> SyncClient::ping() {
  auto r = request(msg::Ping{msg::Rest{"ping"}}, options_.timeout_ms);
  if (!r) return r.error();
  if (r->code != static_cast<uint8_t>(Code::reply_ok) || r->body != "ping") {
    return fail(Errc::protocol_error, "PING: unexpected reply");
  }
  return {};
}

}  // namespace skr::sat
