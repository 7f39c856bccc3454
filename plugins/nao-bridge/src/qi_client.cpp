// SPDX-License-Identifier: Apache-2.0
#include "qi_client.h"

#include <poll.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace skr::nao::qi {

QiClient::~QiClient() {
  close("client destroyed");
}

Result<void> QiClient::connect(const ClientOptions& options) {
  close("reconnecting");
  options_ = options;
  auto link = openLink(Endpoint{options.host, options.port});
  if (!link) return link.error();
  // The endpoints the directory's server listens on: services that list one of them are served
  // by that server, over this connection.
  auto sd = serviceInfo("ServiceDirectory");
  if (sd) {
    directory_ = std::move(sd.value());
  } else if (sd.error().code != Errc::not_found) {
    close(sd.error().message);
    return sd.error();
  }
  return {};
}

void QiClient::close(const std::string& why) {
  for (auto& l : links_) {
    if (l) l->close();
  }
  links_.clear();
  services_.clear();
  lost_.clear();
  directory_.reset();
  auto pending = std::move(pending_);
  pending_.clear();
  for (auto& [id, p] : pending) {
    if (p.fn) p.fn(makeError(Errc::closed, why));
  }
}

Result<std::size_t> QiClient::openLink(const Endpoint& to) {
  auto c = QiConnection::dial(to, options_.connect_timeout_ms, options_.max_payload);
  if (!c) return c.error();
  std::size_t link = links_.size();
  for (std::size_t i = 1; i < links_.size(); ++i) {
    if (!links_[i]) {
      link = i;
      break;
    }
  }
  if (link == links_.size()) links_.emplace_back();
  links_[link] = std::make_unique<QiConnection>(std::move(c.value()));
  if (options_.authenticate) {
    auto r = authenticate(link);
    if (!r) {
      dropLink(link, r.error().message);
      return r.error();
    }
  }
  return link;
}

void QiClient::dropLink(std::size_t link, const std::string& why) {
  if (link == 0) {
    close(why);
    return;
  }
  if (link >= links_.size() || !links_[link]) return;
  const std::string what = "connection to " + links_[link]->endpoint().text() + " lost: " + why;
  links_[link]->close();
  links_[link].reset();
  for (auto it = services_.begin(); it != services_.end();) {
    if (it->second.link != link) {
      ++it;
      continue;
    }
    lost_[it->first] = what;
    it = services_.erase(it);
  }
  std::vector<ReplyFn> fail;
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (it->second.link != link) {
      ++it;
      continue;
    }
    fail.push_back(std::move(it->second.fn));
    it = pending_.erase(it);
  }
  for (ReplyFn& fn : fail) {
    if (fn) fn(makeError(Errc::closed, what));
  }
}

std::map<std::string, std::string> QiClient::takeLost() {
  return std::exchange(lost_, {});
}

std::size_t QiClient::connections() const noexcept {
  std::size_t n = 0;
  for (const auto& l : links_) n += (l && l->open()) ? 1 : 0;
  return n;
}

// The client's capabilities as a {sm} map; the server answers with its own and
// "__qi_auth_state" (1 error, 2 continue, 3 done).
Result<void> QiClient::authenticate(std::size_t link) {
  std::vector<std::pair<Value, Value>> caps = {
      {Value::string("ClientServerSocket"), Value::boolean(true)},
      {Value::string("MessageFlags"), Value::boolean(true)},
      {Value::string("MetaObjectCache"), Value::boolean(false)},
      {Value::string("RemoteCancelableCalls"), Value::boolean(false)},
  };
  if (!options_.user.empty()) {
    caps.emplace_back(Value::string("auth_user"), Value::string(options_.user));
    caps.emplace_back(Value::string("auth_token"), Value::string(options_.token));
  }
  auto payload = encode("{sm}", Value::map(std::move(caps)));
  if (!payload) return payload.error();
  const std::string where = links_[link]->endpoint().text();
  auto reply = wait(link, kServiceServer, 0, kActionAuthenticate, payload.value(), {"{sm}"},
                    options_.lookup_timeout_ms);
  if (!reply) {
    return makeError(reply.error().code, "authenticate at " + where + ": " + reply.error().message);
  }
  const Value* state = reply->find("__qi_auth_state");
  if (state == nullptr || !state->isNumber()) {
    return makeError(Errc::protocol_error,
                     "authenticate at " + where + ": no __qi_auth_state in the answer");
  }
  if (state->asInt() == 3) return {};
  return makeError(Errc::remote, "authenticate at " + where + ": refused (state " +
                                     std::to_string(state->asInt()) +
                                     "; token-based authentication is not supported)");
}

Result<void> QiClient::send(std::size_t link, std::uint32_t service, std::uint32_t object,
                            std::uint32_t action, const std::string& payload,
                            std::vector<std::string> return_sigs, int timeout_ms, ReplyFn fn) {
  if (link >= links_.size() || !links_[link] || !links_[link]->open()) {
    return makeError(Errc::closed, "not connected");
  }
  Header h;
  h.id = next_id_++;
  h.type = MsgType::call;
  h.service = service;
  h.object = object;
  h.action = action;
  auto r = links_[link]->write(encodeMessage(h, payload));
  if (!r) {
    dropLink(link, r.error().message);
    return r;
  }
  pending_[h.id] = Pending{link, std::move(return_sigs),
                           monotonicNs() + std::int64_t{timeout_ms} * 1'000'000, std::move(fn)};
  return {};
}

Result<Value> QiClient::wait(std::size_t link, std::uint32_t service, std::uint32_t object,
                             std::uint32_t action, const std::string& payload,
                             std::vector<std::string> return_sigs, int timeout_ms) {
  std::optional<Result<Value>> answer;
  auto r = send(link, service, object, action, payload, std::move(return_sigs), timeout_ms,
                [&answer](Result<Value> v) { answer.emplace(std::move(v)); });
  if (!r) return r.error();
  const std::string where = links_[link]->endpoint().text();
  while (!answer) {
    auto p = pump(50);
    if (!p && !answer) return p.error();
  }
  // A connection that leaves a look-up unanswered cannot be trusted with the next one.
  if (!*answer && answer->error().code == Errc::timeout) {
    dropLink(link, where + " did not answer a look-up in time");
  }
  return std::move(*answer);
}

Result<ServiceInfo> QiClient::serviceInfo(const std::string& name) {
  auto payload = encode("s", Value::string(name));
  if (!payload) return payload.error();
  // libqi 4 answers with seven fields, earlier releases with six.
  auto v = wait(0, kServiceDirectory, kMainObject, kActionService, payload.value(),
                {kServiceInfoSignature, kServiceInfoSignature6}, options_.lookup_timeout_ms);
  if (!v) {
    if (v.error().code == Errc::remote) {
      const char* hint = options_.authenticate
                             ? ""
                             : " (\"authenticate\" is off: NAOqi 2.5 and later refuse every call "
                               "before the capability map)";
      return makeError(Errc::not_found, "service " + name + ": " + v.error().message + hint);
    }
    return v.error();
  }
  return toServiceInfo(v.value());
}

Result<MetaObject> QiClient::metaObject(std::uint32_t service, std::uint32_t object,
                                        std::size_t link) {
  auto payload = encode("I", Value::integer(object, 'I'));
  if (!payload) return payload.error();
  auto v = wait(link, service, object, kActionMetaObject, payload.value(), {kMetaObjectSignature},
                options_.lookup_timeout_ms);
  if (!v) return v.error();
  return toMetaObject(v.value());
}

bool QiClient::isDirectoryEndpoint(const Endpoint& e) const {
  if (!connected()) return false;
  const Endpoint& at = links_[0]->endpoint();
  if (at.host == e.host && at.port == e.port) return true;
  if (!directory_) return false;
  for (const std::string& url : directory_->endpoints) {
    auto d = parseEndpoint(url);
    if (d && d->host == e.host && d->port == e.port) return true;
  }
  return false;
}

// The connection for a service, chosen by the endpoints its look-up lists, as libqi does: the
// directory's when it lists the endpoint that connection reached or one the directory lists
// (the same listening socket, so the same server); else an open one to an endpoint it lists;
// else a new one to the first it lists that answers. Loopback endpoints are the robot's own
// unless the robot was reached over loopback too, so they are skipped otherwise.
Result<std::size_t> QiClient::linkFor(const ServiceInfo& info) {
  if (info.endpoints.empty()) {
    return makeError(Errc::not_found, "its look-up lists no endpoint");
  }
  std::vector<Endpoint> candidates;
  std::string skipped;
  for (const std::string& url : info.endpoints) {
    auto e = parseEndpoint(url);
    if (!e) {
      skipped += " " + url + " (" + e.error().message + ")";
      continue;
    }
    if (isDirectoryEndpoint(e.value())) return std::size_t{0};
    if (isLoopback(e->host) && !isLoopback(options_.host)) {
      skipped += " " + url + " (the robot's own loopback)";
      continue;
    }
    candidates.push_back(std::move(e.value()));
  }
  for (const Endpoint& e : candidates) {
    for (std::size_t i = 1; i < links_.size(); ++i) {
      if (!links_[i] || !links_[i]->open()) continue;
      const Endpoint& at = links_[i]->endpoint();
      if (at.host == e.host && at.port == e.port) return i;
    }
  }
  Error last = makeError(Errc::unsupported, "no endpoint this client can use:" + skipped);
  for (const Endpoint& e : candidates) {
    auto link = openLink(e);
    if (link) return link;
    last = link.error();
    if (!connected()) break;
  }
  return last;
}

Result<const QiClient::Service*> QiClient::lookup(const std::string& name) {
  auto it = services_.find(name);
  if (it != services_.end()) return &it->second;
  auto info = serviceInfo(name);
  if (!info) return info.error();
  auto link = linkFor(info.value());
  if (!link) {
    std::string at;
    for (const std::string& e : info->endpoints) at += " " + e;
    return makeError(link.error().code, name + " is served at" + at + ": " + link.error().message);
  }
  auto meta = metaObject(info->service_id, kMainObject, link.value());
  if (!meta) return makeError(meta.error().code, name + ".metaObject: " + meta.error().message);
  auto& s = services_[name];
  s.info = std::move(info.value());
  s.meta = std::move(meta.value());
  s.link = link.value();
  return &s;
}

Result<void> QiClient::resolve(const std::string& service) {
  auto s = lookup(service);
  if (!s) return s.error();
  return {};
}

std::string QiClient::endpointOf(const std::string& service) const {
  auto it = services_.find(service);
  if (it == services_.end() || it->second.link >= links_.size() || !links_[it->second.link]) {
    return "";
  }
  return links_[it->second.link]->endpoint().text();
}

Result<void> QiClient::call(const std::string& service, const std::string& method,
                            std::vector<Value> args, int timeout_ms, ReplyFn fn) {
  auto s = lookup(service);
  if (!s) return s.error();
  const MetaMethod* m = s.value()->meta.resolve(method, args);
  if (m == nullptr) {
    return makeError(Errc::not_found,
                     service + "." + method + ": no overload accepts " + Value::tuple(args).text());
  }
  std::string payload;
  auto params = parseSignature(m->parameters_signature);
  if (!params) return params.error();
  auto r = encode(params.value(), Value::tuple(std::move(args)), payload);
  if (!r) return r;
  return send(s.value()->link, s.value()->info.service_id, kMainObject, m->uid, payload,
              {m->return_signature}, timeout_ms, std::move(fn));
}

Result<Value> QiClient::callSync(const std::string& service, const std::string& method,
                                 std::vector<Value> args, int timeout_ms) {
  std::optional<Result<Value>> answer;
  auto r = call(service, method, std::move(args), timeout_ms,
                [&answer](Result<Value> v) { answer.emplace(std::move(v)); });
  if (!r) return r.error();
  while (!answer) {
    auto p = pump(50);
    if (!p && !answer) return p.error();
  }
  return std::move(*answer);
}

void QiClient::dispatch(std::size_t link, Message&& m) {
  if (m.header.type != MsgType::reply && m.header.type != MsgType::error) return;  // events
  auto it = pending_.find(m.header.id);
  if (it == pending_.end() || it->second.link != link) return;  // late, or not ours
  Pending p = std::move(it->second);
  pending_.erase(it);
  if (!p.fn) return;
  if (m.header.type == MsgType::error) {
    auto v = decode("m", m.payload);
    std::string text = v ? (v->kind() == Value::Kind::string ? v->asString() : v->text())
                         : "undecodable error (" + v.error().message + ")";
    p.fn(makeError(Errc::remote, text));
    return;
  }
  const bool dynamic = (m.header.flags & kFlagDynamicPayload) != 0;
  std::optional<Result<Value>> v;
  if (dynamic) {
    v.emplace(decode("m", m.payload));
  } else {
    for (const std::string& sig : p.return_sigs) {
      auto d = decode(sig, m.payload);  // must fill the payload exactly
      if (d || !v) v.emplace(std::move(d));
      if (*v) break;
    }
  }
  if (!v || !*v) {
    // A reply that does not match its signature: the stream cannot be trusted any more.
    const std::string why =
        "QI-PROTOCOL reply " + std::to_string(m.header.id) + " (" +
        (dynamic                 ? std::string("m")
         : p.return_sigs.empty() ? std::string()
                                 : p.return_sigs[0]) +
        "): " + (v ? v->error().message : std::string("no signature to read it with"));
    p.fn(makeError(Errc::protocol_error, why));
    dropLink(link, why);
    return;
  }
  p.fn(std::move(*v));
}

void QiClient::expire() {
  const std::int64_t now = monotonicNs();
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (it->second.deadline_ns > now) {
      ++it;
      continue;
    }
    ReplyFn fn = std::move(it->second.fn);
    it = pending_.erase(it);
    if (fn) fn(makeError(Errc::timeout, "no answer in time"));
  }
}

Result<void> QiClient::pump(int timeout_ms, int wake_fd) {
  if (!connected()) return makeError(Errc::closed, "not connected");
  std::vector<pollfd> p;
  std::vector<std::size_t> polled;  // the link of each pollfd before the wake fd
  for (std::size_t i = 0; i < links_.size(); ++i) {
    if (!links_[i] || !links_[i]->open()) continue;
    p.push_back({links_[i]->fd(), POLLIN, 0});
    polled.push_back(i);
  }
  if (wake_fd >= 0) p.push_back({wake_fd, POLLIN, 0});
  const int n = ::poll(p.data(), p.size(), timeout_ms);
  if (n < 0 && errno != EINTR) {
    Error e = makeError(Errc::io_error, std::string("poll: ") + std::strerror(errno));
    close(e.message);
    return e;
  }
  // A callback may open or drop links; those opened wait for the next pump.
  for (std::size_t k = 0; n > 0 && k < polled.size(); ++k) {
    if ((p[k].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
    const std::size_t i = polled[k];
    if (i >= links_.size() || !links_[i] || links_[i]->fd() != p[k].fd) continue;
    std::vector<Message> got;
    auto r = links_[i]->read(got);
    for (Message& m : got) {
      dispatch(i, std::move(m));
      if (!connected()) return makeError(Errc::closed, "closed during dispatch");
      if (!links_[i]) break;
    }
    if (!r) {
      if (i == 0) {
        close(r.error().message);
        return r;
      }
      dropLink(i, r.error().message);
    }
  }
  expire();
  return {};
}

}  // namespace skr::nao::qi
