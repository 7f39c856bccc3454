// LocalClient: a module's satellite inside the hub. Same channels, no socket, no copies; its
// failures are the Results of the server's parts, so a module gets the Errc a satellite gets.
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
      (void)server.requests.respond(*this, ch.id, request,
                                    Variant("this module answers no requests"));
    }
  }
  void onResponse(uint16_t chan_id, uint32_t tag, bool, ErrorCode error,
                  const Variant& value) override {
    if (handlers.on_response) handlers.on_response(chan_id, tag, toErrc(error), value);
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
  if (!impl_->auth || !impl_->auth->hasUser(account)) return nullptr;
  return impl_->auth->accessOf(account);
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

Result<uint16_t> LocalClient::createChannel(const std::string& short_name, ChannelKind kind,
                                            const std::string& mime, const Variant& props) {
  auto r = impl_->server.createChannel(*impl_, short_name, kind, mime, props, 0);
  if (!r) return r.error();
  return (*r)->id;
}

Result<void> LocalClient::removeChannel(uint16_t chan_id) {
  return impl_->server.removeChannel(*impl_, chan_id);
}

std::optional<uint16_t> LocalClient::findChannel(const std::string& name) const {
  if (const Channel* ch = impl_->server.channels.findByName(name)) return ch->id;
  return std::nullopt;
}

Result<void> LocalClient::publish(uint16_t chan_id, std::string_view payload) {
  return impl_->server.channels.publish(*impl_, chan_id, payload);
}

Result<void> LocalClient::subscribe(const std::string& name) {
  ChannelTable& channels = impl_->server.channels;
  channels.want(name, impl_->id);
  if (const Channel* ch = channels.findByName(name)) return channels.subscribe(*impl_, ch->id);
  return {};  // waits for the channel
}

void LocalClient::unsubscribe(const std::string& name) {
  ChannelTable& channels = impl_->server.channels;
  channels.unwant(name, impl_->id);
  if (const Channel* ch = channels.findByName(name)) (void)channels.unsubscribe(*impl_, ch->id);
}

Result<void> LocalClient::request(uint16_t chan_id, uint32_t tag, const std::string& command,
                                  const Variant& value) {
  return impl_->server.requests.request(*impl_, chan_id, tag, false, 0, command, value);
}

Result<void> LocalClient::respond(uint16_t chan_id, uint64_t request, const Variant& value) {
  return impl_->server.requests.respond(*impl_, chan_id, request, value);
}

std::optional<Variant> LocalClient::getVariable(const std::string& db, const std::string& key) {
  const PairDatabase* d = impl_->server.databases.store().find(db);
  if (d == nullptr) return std::nullopt;
  if (const Variant* v = d->get(key)) return *v;
  return std::nullopt;
}

Result<void> LocalClient::setVariable(const std::string& db, const std::string& key,
                                      const Variant& value) {
  return impl_->server.databases.setVar(*impl_, db, key, value);
}

void LocalClient::syncDatabases(std::function<void(Result<void>)> done) {
  impl_->server.databases.store().barrier(std::move(done));
}

}  // namespace skr::flow
