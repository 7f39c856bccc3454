// LocalClient: a module's satellite inside the hub. Same channels, no socket, no copies.
#include "server_impl.h"

#include <skrobot/core/log.h>

namespace skr::flow {

struct LocalClient::Impl final : Endpoint {
  Impl(FlowServer::Impl& s, LocalHandlers h) : server(s), handlers(std::move(h)) {}
  ~Impl() override = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  Impl(Impl&&) = delete;
  Impl& operator=(Impl&&) = delete;

  FlowServer::Impl& server;
  LocalHandlers handlers;

  [[nodiscard]] bool receivesEvents() const override { return true; }
  [[nodiscard]] bool congested() const override { return false; }
  [[nodiscard]] std::string describe() const override {
    return "module " + client_name + " (" + user + ")";
  }
  void onData(const Channel& ch, std::string_view payload) override {
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
      std::string why;
      (void)server.respond(*this, ch.id, request, Variant("this module answers no requests"), why);
    }
  }
  void onResponse(uint16_t chan_id, uint32_t tag, bool, ErrorCode error,
                  const Variant& value) override {
    if (handlers.on_response) handlers.on_response(chan_id, tag, error, value);
  }
  void onChannelAdded(const Channel& ch, uint32_t) override {
    if (handlers.on_channel) handlers.on_channel(ch.id, ch.name, true);
  }
  void onChannelRemoved(const Channel& ch) override {
    if (handlers.on_channel) handlers.on_channel(ch.id, ch.name, false);
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
};

std::unique_ptr<LocalClient> FlowServer::attachLocal(const std::string& user,
                                                     const std::string& name,
                                                     LocalHandlers handlers) {
  auto impl = std::make_unique<LocalClient::Impl>(*impl_, std::move(handlers));
  impl->user = user;
  impl->client_name = name;
  impl_->addEndpoint(impl.get());
  impl_->loggedIn(*impl);
  return std::make_unique<LocalClient>(std::move(impl));
}

LocalClient::LocalClient(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

LocalClient::~LocalClient() {
  impl_->server.removeEndpoint(*impl_);
}

const std::string& LocalClient::user() const noexcept {
  return impl_->user;
}
uint32_t LocalClient::id() const noexcept {
  return impl_->id;
}

namespace {
Result<void> asResult(ErrorCode e, const std::string& why) {
  if (e == ErrorCode::ok) return {};
  return makeError(e == ErrorCode::not_found           ? Errc::not_found
                   : e == ErrorCode::permission_denied ? Errc::permission_denied
                   : e == ErrorCode::overflow          ? Errc::limit_exceeded
                                                       : Errc::invalid_argument,
                   why);
}
}  // namespace

Result<uint16_t> LocalClient::createChannel(const std::string& short_name, ChannelKind kind,
                                            const std::string& mime, const Variant& props) {
  auto r = impl_->server.createChannel(*impl_, short_name, kind, mime, props, 0);
  if (!r) return r.error();
  return (*r)->id;
}

Result<void> LocalClient::removeChannel(uint16_t chan_id) {
  std::string why;
  return asResult(impl_->server.removeChannel(*impl_, chan_id, why), why);
}

std::optional<uint16_t> LocalClient::findChannel(const std::string& name) const {
  if (const Channel* ch = impl_->server.channelByName(name)) return ch->id;
  return std::nullopt;
}

Result<void> LocalClient::publish(uint16_t chan_id, std::string_view payload) {
  std::string why;
  return asResult(impl_->server.publish(*impl_, chan_id, payload, why), why);
}

Result<void> LocalClient::subscribe(const std::string& name) {
  auto& s = impl_->server;
  bool known = false;
  auto [lo, hi] = s.local_wanted.equal_range(name);
  for (auto it = lo; it != hi; ++it) known = known || it->second == impl_->id;
  if (!known) s.local_wanted.emplace(name, impl_->id);
  if (const Channel* ch = s.channelByName(name)) {
    std::string why;
    return asResult(s.subscribe(*impl_, ch->id, why), why);
  }
  return {};  // waits for the channel
}

void LocalClient::unsubscribe(const std::string& name) {
  auto& s = impl_->server;
  auto [lo, hi] = s.local_wanted.equal_range(name);
  for (auto it = lo; it != hi;) {
    it = it->second == impl_->id ? s.local_wanted.erase(it) : std::next(it);
  }
  if (const Channel* ch = s.channelByName(name)) {
    std::string why;
    (void)s.unsubscribe(*impl_, ch->id, why);
  }
}

Result<void> LocalClient::request(uint16_t chan_id, uint32_t tag, const std::string& command,
                                  const Variant& value) {
  std::string why;
  return asResult(impl_->server.request(*impl_, chan_id, tag, false, 0, command, value, why), why);
}

Result<void> LocalClient::respond(uint16_t chan_id, uint64_t request, const Variant& value) {
  std::string why;
  return asResult(impl_->server.respond(*impl_, chan_id, request, value, why), why);
}

std::optional<Variant> LocalClient::getVariable(const std::string& db, const std::string& key) {
  const PairDatabase* d = impl_->server.dbs.find(db);
  if (d == nullptr) return std::nullopt;
  if (const Variant* v = d->get(key)) return *v;
  return std::nullopt;
}

Result<void> LocalClient::setVariable(const std::string& db, const std::string& key,
                                      const Variant& value) {
  std::string why;
  return asResult(impl_->server.setVar(*impl_, db, key, value, why), why);
}

}  // namespace skr::flow
