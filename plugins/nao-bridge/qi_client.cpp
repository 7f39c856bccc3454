#include "qi_client.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <optional>

namespace nao::qi {

std::int64_t monotonicNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

namespace {

int msLeft(std::int64_t deadline_ns) {
  const std::int64_t left = (deadline_ns - monotonicNs()) / 1'000'000;
  return left < 0 ? 0 : static_cast<int>(left > 60'000 ? 60'000 : left);
}

Error sysError(const std::string& what) {
  return fail(Errc::io, what + ": " + std::strerror(errno));
}

// A non-blocking TCP connection to host:port within timeout_ms.
Result<int> dial(const std::string& host, std::uint16_t port, int timeout_ms) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* list = nullptr;
  const int gai = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &list);
  if (gai != 0) return fail(Errc::io, "resolve " + host + ": " + ::gai_strerror(gai));
  Error last = fail(Errc::io, "no address for " + host);
  const std::int64_t deadline = monotonicNs() + std::int64_t{timeout_ms} * 1'000'000;
  for (addrinfo* a = list; a != nullptr; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
      last = sysError("socket");
      continue;
    }
    if (::connect(fd, a->ai_addr, a->ai_addrlen) != 0 && errno != EINPROGRESS) {
      last = sysError("connect " + host + ":" + std::to_string(port));
      ::close(fd);
      continue;
    }
    pollfd p{fd, POLLOUT, 0};
    const int n = ::poll(&p, 1, msLeft(deadline));
    int err = 0;
    socklen_t len = sizeof(err);
    if (n <= 0) {
      last = fail(Errc::timeout, "connect " + host + ":" + std::to_string(port) + ": timed out");
    } else if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0 || err != 0) {
      errno = err;
      last = sysError("connect " + host + ":" + std::to_string(port));
    } else {
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
      ::freeaddrinfo(list);
      return fd;
    }
    ::close(fd);
  }
  ::freeaddrinfo(list);
  return last;
}

}  // namespace

QiClient::~QiClient() {
  close("client destroyed");
}

Result<void> QiClient::connect(const ClientOptions& options) {
  close("reconnecting");
  options_ = options;
  framer_ = MessageFramer(options.max_payload);
  services_.clear();
  auto fd = dial(options.host, options.port, options.connect_timeout_ms);
  if (!fd) return fd.error();
  fd_ = fd.value();
  if (options.authenticate) {
    auto r = authenticate();
    if (!r) {
      close(r.error().message);
      return r;
    }
  }
  return {};
}

void QiClient::close(const std::string& why) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  auto pending = std::move(pending_);
  pending_.clear();
  for (auto& [id, p] : pending) {
    if (p.fn) p.fn(fail(Errc::closed, why));
  }
}

// The client's capabilities as a {sm} map; the server answers with its own and
// "__qi_auth_state" (1 error, 2 continue, 3 done).
Result<void> QiClient::authenticate() {
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
  auto reply = wait(kServiceServer, 0, kActionAuthenticate, payload.value(), "{sm}",
                    options_.lookup_timeout_ms);
  if (!reply) return fail(reply.error().code, "authenticate: " + reply.error().message);
  const Value* state = reply->find("__qi_auth_state");
  if (state == nullptr || !state->isNumber()) {
    return fail(Errc::protocol, "authenticate: no __qi_auth_state in the answer");
  }
  if (state->asInt() == 3) return {};
  return fail(Errc::remote, "authenticate: refused (state " + std::to_string(state->asInt()) +
                                "; token-based authentication is not supported)");
}

Result<void> QiClient::writeAll(const std::string& bytes) {
  if (fd_ < 0) return fail(Errc::closed, "not connected");
  const std::int64_t deadline = monotonicNs() + 2'000'000'000;
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd_, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      Error e = sysError("send");
      close(e.message);
      return e;
    }
    pollfd p{fd_, POLLOUT, 0};
    if (::poll(&p, 1, msLeft(deadline)) <= 0) {
      close("send: the robot does not read");
      return fail(Errc::timeout, "send: the robot does not read");
    }
  }
  return {};
}

Result<void> QiClient::send(std::uint32_t service, std::uint32_t object, std::uint32_t action,
                            const std::string& payload, std::string return_sig, int timeout_ms,
                            ReplyFn fn) {
  if (fd_ < 0) return fail(Errc::closed, "not connected");
  Header h;
  h.id = next_id_++;
  h.type = MsgType::call;
  h.service = service;
  h.object = object;
  h.action = action;
  auto r = writeAll(encodeMessage(h, payload));
  if (!r) return r;
  pending_[h.id] = Pending{std::move(return_sig),
                           monotonicNs() + std::int64_t{timeout_ms} * 1'000'000, std::move(fn)};
  return {};
}

Result<Value> QiClient::wait(std::uint32_t service, std::uint32_t object, std::uint32_t action,
                             const std::string& payload, const std::string& return_sig,
                             int timeout_ms) {
  std::optional<Result<Value>> answer;
  auto r = send(service, object, action, payload, return_sig, timeout_ms,
                [&answer](Result<Value> v) { answer.emplace(std::move(v)); });
  if (!r) return r.error();
  while (!answer) {
    auto p = pump(50);
    if (!p && !answer) return p.error();
  }
  return std::move(*answer);
}

Result<ServiceInfo> QiClient::serviceInfo(const std::string& name) {
  auto payload = encode("s", Value::string(name));
  if (!payload) return payload.error();
  auto v = wait(kServiceDirectory, kMainObject, kActionService, payload.value(),
                kServiceInfoSignature, options_.lookup_timeout_ms);
  if (!v) {
    if (v.error().code == Errc::remote) {
      return fail(Errc::not_found, "service " + name + ": " + v.error().message);
    }
    return v.error();
  }
  return toServiceInfo(v.value());
}

Result<MetaObject> QiClient::metaObject(std::uint32_t service, std::uint32_t object) {
  auto payload = encode("I", Value::integer(object, 'I'));
  if (!payload) return payload.error();
  auto v = wait(service, object, kActionMetaObject, payload.value(), kMetaObjectSignature,
                options_.lookup_timeout_ms);
  if (!v) return v.error();
  return toMetaObject(v.value());
}

Result<const QiClient::Service*> QiClient::lookup(const std::string& name) {
  auto it = services_.find(name);
  if (it != services_.end()) return &it->second;
  auto info = serviceInfo(name);
  if (!info) return info.error();
  auto meta = metaObject(info->service_id, kMainObject);
  if (!meta) return fail(meta.error().code, name + ".metaObject: " + meta.error().message);
  auto& s = services_[name];
  s.info = std::move(info.value());
  s.meta = std::move(meta.value());
  return &s;
}

Result<void> QiClient::resolve(const std::string& service) {
  auto s = lookup(service);
  if (!s) return s.error();
  return {};
}

Result<void> QiClient::call(const std::string& service, const std::string& method,
                            std::vector<Value> args, int timeout_ms, ReplyFn fn) {
  auto s = lookup(service);
  if (!s) return s.error();
  const MetaMethod* m = s.value()->meta.resolve(method, args);
  if (m == nullptr) {
    return fail(Errc::not_found,
                service + "." + method + ": no overload accepts " + Value::tuple(args).text());
  }
  std::string payload;
  auto params = parseSignature(m->parameters_signature);
  if (!params) return params.error();
  auto r = encode(params.value(), Value::tuple(std::move(args)), payload);
  if (!r) return r;
  return send(s.value()->info.service_id, kMainObject, m->uid, payload, m->return_signature,
              timeout_ms, std::move(fn));
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

void QiClient::dispatch(Message&& m) {
  if (m.header.type != MsgType::reply && m.header.type != MsgType::error) return;  // events
  auto it = pending_.find(m.header.id);
  if (it == pending_.end()) return;  // late reply of an expired call
  Pending p = std::move(it->second);
  pending_.erase(it);
  if (!p.fn) return;
  if (m.header.type == MsgType::error) {
    auto v = decode("m", m.payload);
    std::string text = v ? (v->kind() == Value::Kind::string ? v->asString() : v->text())
                         : "undecodable error (" + v.error().message + ")";
    p.fn(fail(Errc::remote, text));
    return;
  }
  const bool dynamic = (m.header.flags & kFlagDynamicPayload) != 0;
  auto v = decode(dynamic ? std::string("m") : p.return_sig, m.payload);
  if (!v) {
    // A reply that does not match its signature: the stream cannot be trusted any more.
    const std::string why = "QI-PROTOCOL reply " + std::to_string(m.header.id) + " (" +
                            p.return_sig + "): " + v.error().message;
    p.fn(fail(Errc::protocol, why));
    close(why);
    return;
  }
  p.fn(std::move(v));
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
    if (fn) fn(fail(Errc::timeout, "no answer in time"));
  }
}

Result<void> QiClient::pump(int timeout_ms, int wake_fd) {
  if (fd_ < 0) return fail(Errc::closed, "not connected");
  pollfd p[2] = {{fd_, POLLIN, 0}, {wake_fd, POLLIN, 0}};
  const int n = ::poll(p, wake_fd >= 0 ? 2 : 1, timeout_ms);
  if (n < 0 && errno != EINTR) {
    Error e = sysError("poll");
    close(e.message);
    return e;
  }
  if (n > 0 && (p[0].revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
    char buf[16384];
    for (;;) {
      const ssize_t got = ::recv(fd_, buf, sizeof(buf), 0);
      if (got > 0) {
        framer_.append(std::string_view(buf, static_cast<std::size_t>(got)));
        if (static_cast<std::size_t>(got) < sizeof(buf)) break;
        if (framer_.buffered() > options_.max_payload + kHeaderSize) break;  // frame it first
        continue;
      }
      if (got < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) break;
      Error e = got == 0 ? fail(Errc::closed, "connection closed by the robot") : sysError("recv");
      close(e.message);
      return e;
    }
    for (;;) {
      auto m = framer_.next();
      if (!m) {
        Error e = fail(Errc::protocol, "QI-PROTOCOL " + m.error().message);
        close(e.message);
        return e;
      }
      if (!m.value()) break;
      dispatch(std::move(*m.value()));
      if (fd_ < 0) return fail(Errc::closed, "closed during dispatch");
    }
  }
  expire();
  return {};
}

}  // namespace nao::qi
