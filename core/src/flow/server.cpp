// SPDX-License-Identifier: Apache-2.0
// FlowServer: transports, connection lifecycle, output flushing and timeouts (server_impl.h).
#include "server_impl.h"

#include "connection.h"
#include "uv_handle.h"

#include <skrobot/runtime/log.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <vector>

namespace skr::flow {
namespace {

// Whether a listening address is reachable from this machine only.
bool isLoopback(const std::string& address) {
  return address == "localhost" || address == "::1" || address.starts_with("127.");
}

}  // namespace

FlowServer::Impl::Impl(Loop& l, ServerOptions options) : Hub(l, std::move(options)) {
  unix_path = opt.unix_path.empty() ? "/tmp/" + opt.app_name : opt.unix_path;
}

Result<void> FlowServer::Impl::start() {
  if (started) return {};
  // libuv writes with write(2): a satellite that closes while the hub writes to it would raise
  // SIGPIPE and kill the whole hub. Ignored, the write fails with EPIPE and only that
  // connection closes.
  std::signal(SIGPIPE, SIG_IGN);
  // The rooms, in order: the databases are loaded, the blob stores opened, the accounts read.
  for (Room* room : lifecycle()) {
    if (auto r = room->start(); !r) {
      stop();
      return r;
    }
  }

  flush_prepare = newUvHandle<uv_prepare_t>(this);
  uv_prepare_init(loop.uv(), flush_prepare);
  uv_prepare_start(flush_prepare,
                   [](uv_prepare_t* h) { static_cast<Impl*>(h->data)->flushDirty(); });
  flush_check = newUvHandle<uv_check_t>(this);
  uv_check_init(loop.uv(), flush_check);
  uv_check_start(flush_check, [](uv_check_t* h) { static_cast<Impl*>(h->data)->flushDirty(); });
  sweep_timer = newUvHandle<uv_timer_t>(this);
  uv_timer_init(loop.uv(), sweep_timer);
  uv_timer_start(
      sweep_timer,
      [](uv_timer_t* h) { static_cast<Impl*>(h->data)->sweep(monotonicNs()); }, 20, 20);

  if (opt.tcp_enabled && opt.tls) {
    // The certificate, key and CA files are read here, once, before the loop serves anyone.
    auto ctx = TlsContext::create(TlsRole::server, *opt.tls);
    if (!ctx) return ctx.error();
    tls = std::move(ctx).value();
  }

  if (opt.unix_enabled) {
    if (auto r = listenUnix(); !r) {
      stop();
      return r;
    }
  }
  if (opt.tcp_enabled) {
    if (auto r = listenTcp(); !r) {
      stop();
      return r;
    }
  }
  started = true;
  links.connect();
  return {};
}

Result<void> FlowServer::Impl::listenUnix() {
  // A socket file left by a hub that crashed would make bind fail: remove it, but only if no
  // hub answers on it (two hubs with the same app name must not steal each other's socket).
  struct stat st {};
  if (lstat(unix_path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      return makeError(Errc::already_exists, unix_path + " exists and is not a socket");
    }
    const int probe = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, unix_path.c_str(), sizeof(addr.sun_path) - 1);
    const bool live = ::connect(probe, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    ::close(probe);
    if (live) return makeError(Errc::already_exists, "another hub listens on " + unix_path);
    ::unlink(unix_path.c_str());
  }
  unix_listener = newUvHandle<uv_pipe_t>(this);
  uv_pipe_init(loop.uv(), unix_listener, 0);
  int rc = uv_pipe_bind(unix_listener, unix_path.c_str());
  if (rc == 0) {
    rc = uv_listen(reinterpret_cast<uv_stream_t*>(unix_listener), 128,
                   [](uv_stream_t* l, int status) {
                     if (status == 0) {
                       static_cast<Impl*>(l->data)->accept(l, Transport::unix_socket);
                     }
                   });
  }
  if (rc != 0) {
    closeUvHandle(unix_listener);
    return makeError(Errc::io_error, "cannot listen on " + unix_path + ": " + uv_strerror(rc));
  }
  ::chmod(unix_path.c_str(), 0660);
  log::info(kLogSource, "FLOW-LISTEN", "Unix socket " + unix_path);
  return {};
}

Result<void> FlowServer::Impl::listenTcp() {
  sockaddr_storage addr{};
  int rc =
      uv_ip4_addr(opt.tcp_address.c_str(), opt.tcp_port, reinterpret_cast<sockaddr_in*>(&addr));
  if (rc != 0) {
    rc = uv_ip6_addr(opt.tcp_address.c_str(), opt.tcp_port, reinterpret_cast<sockaddr_in6*>(&addr));
  }
  if (rc != 0) return makeError(Errc::invalid_argument, "bad TCP address " + opt.tcp_address);
  tcp_listener = newUvHandle<uv_tcp_t>(this);
  uv_tcp_init(loop.uv(), tcp_listener);
  rc = uv_tcp_bind(tcp_listener, reinterpret_cast<sockaddr*>(&addr), 0);
  if (rc == 0) {
    rc = uv_listen(reinterpret_cast<uv_stream_t*>(tcp_listener), 128,
                   [](uv_stream_t* l, int status) {
                     if (status == 0) static_cast<Impl*>(l->data)->accept(l, Transport::tcp);
                   });
  }
  if (rc != 0) {
    closeUvHandle(tcp_listener);
    return makeError(Errc::io_error, "cannot listen on TCP " + opt.tcp_address + ":" +
                                         std::to_string(opt.tcp_port) + ": " + uv_strerror(rc));
  }
  sockaddr_storage bound{};
  int len = sizeof bound;
  uv_tcp_getsockname(tcp_listener, reinterpret_cast<sockaddr*>(&bound), &len);
  tcp_port = ntohs(reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
  const std::string where = opt.tcp_address + ":" + std::to_string(tcp_port);
  if (tls) {
    log::info(kLogSource, "FLOW-LISTEN",
              "TLS " + where + " (TLS " + opt.tls->min_version + " or later, client certificates " +
                  (tls->requiresPeerCertificate() ? "required" : "not asked for") + ")");
  } else {
    log::info(kLogSource, "FLOW-LISTEN", "TCP " + where);
    if (!isLoopback(opt.tcp_address)) {
      log::warn(kLogSource, "FLOW-TCP-PLAIN",
                "serving plain TCP on " + where +
                    ", reachable from other machines: passwords and data cross the network "
                    "unencrypted; configure server.tls (docs/security.md)");
    }
  }
  return {};
}

namespace {

// "tcp:<address>" of a TCP peer, "uid:<n>" of a Unix one: what the login throttle counts by.
std::string peerOf(uv_stream_t* stream, Transport transport) {
  if (transport == Transport::tcp) {
    sockaddr_storage peer{};
    int len = sizeof peer;
    char name[INET6_ADDRSTRLEN] = {};
    if (uv_tcp_getpeername(reinterpret_cast<uv_tcp_t*>(stream), reinterpret_cast<sockaddr*>(&peer),
                           &len) != 0) {
      return "tcp:?";
    }
    if (peer.ss_family == AF_INET6) {
      uv_ip6_name(reinterpret_cast<sockaddr_in6*>(&peer), name, sizeof name);
    } else {
      uv_ip4_name(reinterpret_cast<sockaddr_in*>(&peer), name, sizeof name);
    }
    return std::string("tcp:") + name;
  }
  uv_os_fd_t fd = -1;
  ucred cred{};
  socklen_t len = sizeof cred;
  if (uv_fileno(reinterpret_cast<uv_handle_t*>(stream), &fd) != 0 ||
      ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0) {
    return "unix:?";
  }
  return "uid:" + std::to_string(cred.uid);
}

}  // namespace

void FlowServer::Impl::accept(uv_stream_t* listener, Transport transport) {
  auto* c = new Connection(static_cast<Hub&>(*this), transport);
  bool tls_failed = false;
  if (transport == Transport::tcp && tls) {
    auto session = TlsSession::open(*tls);
    if (session) {
      c->useTls(std::move(session).value());
    } else {
      log::error(kLogSource, "FLOW-TLS", session.error().message);
      tls_failed = true;
    }
  }
  if (transport == Transport::tcp) {
    uv_tcp_init(loop.uv(), reinterpret_cast<uv_tcp_t*>(c->stream()));
  } else {
    uv_pipe_init(loop.uv(), reinterpret_cast<uv_pipe_t*>(c->stream()), 0);
  }
  c->stream()->data = c;
  if (uv_accept(listener, c->stream()) != 0) {
    uv_close(reinterpret_cast<uv_handle_t*>(c->stream()),
             [](uv_handle_t* h) { delete static_cast<Connection*>(h->data); });
    return;
  }
  if (transport == Transport::tcp) uv_tcp_nodelay(reinterpret_cast<uv_tcp_t*>(c->stream()), 1);
  c->source = peerOf(c->stream(), transport);
  endpoints.add(*c);
  connections[c->id] = c;
  ++stats.connections_accepted;
  ++stats.connections_open;
  if (connections.size() > opt.max_connections) {
    log::warn(kLogSource, "FLOW-LIMIT",
              "refusing " + c->describe() + ": " + std::to_string(opt.max_connections) +
                  " connections already");
    // A few are told why, in answer to their LOGIN (closing at once could cut off the answer);
    // beyond those, a flood is closed at once.
    constexpr size_t kToldAtOnce = 16;
    if (connections.size() > opt.max_connections + kToldAtOnce) {
      c->close("too many connections");
      return;
    }
    c->over_limit = true;
  }
  if (tls_failed) {
    c->close("no TLS session");  // never serve plain bytes on the TLS port
    return;
  }
  c->login_deadline = monotonicNs() + static_cast<Nanos>(opt.login_timeout_ms) * kNsPerMs;
  c->startReading();
}

void FlowServer::Impl::stop() noexcept {
  links.stop();  // replicas and links go while everyone is still here to be told
  std::vector<Connection*> all;
  for (auto& [id, c] : connections) all.push_back(c);
  for (Connection* c : all) c->close("hub stopping");
  closeUvHandle(unix_listener);
  closeUvHandle(tcp_listener);
  closeUvHandle(flush_prepare);
  closeUvHandle(flush_check);
  closeUvHandle(sweep_timer);
  if (started) {
    ::unlink(unix_path.c_str());
    started = false;
  }
  // The rooms in reverse: the authenticator's worker ended, what was asked of the blob store run,
  // the databases saved.
  auto order = lifecycle();
  for (auto it = order.rbegin(); it != order.rend(); ++it) (*it)->stop();
}

// --- FlowServer ------------------------------------------------------------------------------

FlowServer::FlowServer(Loop& loop, ServerOptions options)
    : impl_(std::make_unique<Impl>(loop, std::move(options))) {}

// Connections and handles are freed by their close callbacks when the loop next runs; none of
// them touches the server again.
FlowServer::~FlowServer() {
  impl_->stop();
}

Result<void> FlowServer::start() {
  return impl_->start();
}
void FlowServer::stop() noexcept {
  impl_->stop();
}
const ServerOptions& FlowServer::options() const noexcept {
  return impl_->opt;
}
std::string FlowServer::unixPath() const {
  return impl_->unix_path;
}
uint16_t FlowServer::tcpPort() const noexcept {
  return impl_->tcp_port;
}
const ServerStats& FlowServer::stats() const noexcept {
  return impl_->stats;
}
size_t FlowServer::channelCount() const noexcept {
  return impl_->channels.count();
}
const std::string& FlowServer::hubName() const noexcept {
  return impl_->hub_name;
}

}  // namespace skr::flow
