// SPDX-License-Identifier: Apache-2.0
// FlowServer: listeners (transport.h), connection lifecycle, output flushing and timeouts
// (server_impl.h).
#include "server_impl.h"

#include "connection.h"
#include "uv_handle.h"

#include <skrobot/hub/install_layout.h>
#include <skrobot/runtime/log.h>

#include <csignal>
#include <filesystem>
#include <system_error>
#include <vector>

namespace skr::flow {
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
      sweep_timer, [](uv_timer_t* h) { static_cast<Impl*>(h->data)->sweep(monotonicNs()); }, 20,
      20);

  if ((opt.tcp_enabled || opt.web) && opt.tls) {
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
  if (opt.udp) {
    if (auto r = listenUdp(); !r) {
      stop();
      return r;
    }
  }
  if (opt.web) {
    if (auto r = listenWeb(); !r) {
      stop();
      return r;
    }
  }
  serial_ports = std::make_unique<SerialPorts>(
      loop, opt.serial,
      [this](std::unique_ptr<transport::Transport> t, const transport::SerialOptions& port) {
        accept(std::move(t), &port);
      });
  serial_ports->start();
  started = true;
  links.connect();
  return {};
}

Result<void> FlowServer::Impl::listenUnix() {
  Address where;
  where.kind = Address::Kind::local;
  where.path = unix_path;
  auto l = transport::Listener::open(
      loop, where, {}, [this](std::unique_ptr<transport::Transport> t) { accept(std::move(t)); });
  if (!l) return l.error();
  unix_listener = std::move(l).value();
  log::info(kLogSource, "FLOW-LISTEN", "Unix socket " + unix_path);
  return {};
}

Result<void> FlowServer::Impl::listenTcp() {
  transport::ListenOptions options;
  Address address{.kind = Address::Kind::tcp, .host = opt.tcp_address, .port = opt.tcp_port};
  if (tls) {
    address.kind = Address::Kind::tls;
    options.tls = *tls;
    // A plain FlowProtocol client waits for the reply to its LOGIN: it is told in its language.
    (void)encode(options.plain_peer_reply,
                 msg::ReplyError{static_cast<uint16_t>(ErrorCode::protocol_error),
                                 "this hub's TCP port speaks TLS: connect with a tls: address "
                                 "(docs/security.md)"});
  }
  auto l = transport::Listener::open(
      loop, address, std::move(options),
      [this](std::unique_ptr<transport::Transport> t) { accept(std::move(t)); });
  if (!l) return l.error();
  tcp_listener = std::move(l).value();
  tcp_port = tcp_listener->port();
  const std::string where = opt.tcp_address + ":" + std::to_string(tcp_port);
  if (tls) {
    log::info(kLogSource, "FLOW-LISTEN",
              "TLS " + where + " (TLS " + opt.tls->min_version + " or later, client certificates " +
                  (tls->requiresPeerCertificate() ? "required" : "not asked for") + ")");
  } else {
    log::info(kLogSource, "FLOW-LISTEN", "TCP " + where);
    if (!isLoopbackAddress(opt.tcp_address)) {
      log::warn(kLogSource, "FLOW-TCP-PLAIN",
                "serving plain TCP on " + where +
                    ", reachable from other machines: passwords and data cross the network "
                    "unencrypted; configure server.tls (docs/security.md)");
    }
  }
  return {};
}

Result<void> FlowServer::Impl::listenUdp() {
  // The key is looked up in the users file the authenticator holds in memory: no file I/O here.
  auto port = UdpPort::open(
      loop, *opt.udp, [this](std::string_view user) { return session.auth->udpKeyOf(user); },
      [this](std::unique_ptr<transport::Transport> t) { accept(std::move(t)); });
  if (!port) return port.error();
  udp_port = std::move(port).value();
  log::info(kLogSource, "FLOW-LISTEN",
            "UDP " + opt.udp->address + ":" + std::to_string(udp_port->port()) +
                " (boards with a key: skrobot user key NAME)");
  return {};
}

Result<void> FlowServer::Impl::listenWeb() {
  WebOptions w = *opt.web;
  if (w.root.empty()) {
    // The page installed with the hub, or in a build tree the one copied beside bin/.
    std::error_code ec;
    for (const std::filesystem::path& dir :
         {installedDataDir() / "web", (executableDir() / ".." / "web").lexically_normal()}) {
      if (!executableDir().empty() && std::filesystem::is_regular_file(dir / "index.html", ec)) {
        w.root = dir;
        break;
      }
    }
    if (w.root.empty()) {
      log::warn(kLogSource, "FLOW-WEB",
                "no web page installed beside the hub (" + (installedDataDir() / "web").string() +
                    "): the web port serves server.web.mounts only; set server.web.root");
    }
  }
  auto port = WebPort::open(
      loop, w, tls ? &*tls : nullptr, opt.login_timeout_ms, opt.max_connections,
      [this](std::unique_ptr<transport::Transport> t) { accept(std::move(t)); },
      [this](const std::string& address) { return session.issuePageToken(address); });
  if (!port) return port.error();
  web_port = std::move(port).value();
  const std::string where = w.address + ":" + std::to_string(web_port->port());
  log::info(kLogSource, "FLOW-LISTEN",
            std::string(tls ? "HTTPS " : "HTTP ") + where + " (files" +
                (w.root.empty() ? "" : " from " + w.root.string()) +
                (w.flows ? ", flows over WebSocket at /flow" : "") + ")");
  if (!tls && !isLoopbackAddress(w.address)) {
    log::warn(kLogSource, "FLOW-TCP-PLAIN",
              "serving plain HTTP on " + where +
                  ", reachable from other machines: pages, passwords and data cross the network "
                  "unencrypted; configure server.tls (docs/security.md)");
  }
  return {};
}

void FlowServer::Impl::accept(std::unique_ptr<transport::Transport> transport,
                              const transport::SerialOptions* serial) {
  const transport::PeerIdentity peer = transport->peer();
  const std::string source = peer.source();
  auto* c = new Connection(static_cast<Hub&>(*this), std::move(transport));
  c->source = source;
  if (serial != nullptr) {
    c->bound_account = serial->account;
    // A line carries a few KB/s: its data waits in a small queue, newest wins.
    c->limitQueue(serial->queue_bytes);
  }
  // A UDP session was opened with an account's key: that account logs in, without a password.
  if (peer.kind == transport::TransportKind::udp) c->bound_account = peer.account;
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
  c->login_deadline = monotonicNs() + static_cast<Nanos>(opt.login_timeout_ms) * kNsPerMs;
  c->startReading();
}

void FlowServer::Impl::stop() noexcept {
  links.stop();  // replicas and links go while everyone is still here to be told
  std::vector<Connection*> all;
  for (auto& [id, c] : connections) all.push_back(c);
  for (Connection* c : all) c->close("hub stopping");
  unix_listener.reset();  // removes the socket file
  tcp_listener.reset();
  serial_ports.reset();
  udp_port.reset();
  web_port.reset();
  closeUvHandle(flush_prepare);
  closeUvHandle(flush_check);
  closeUvHandle(sweep_timer);
  started = false;
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
uint16_t FlowServer::udpPort() const noexcept {
  return impl_->udp_port ? impl_->udp_port->port() : 0;
}
uint16_t FlowServer::webPort() const noexcept {
  return impl_->web_port ? impl_->web_port->port() : 0;
}

Result<void> FlowServer::serveWebSocket(
    const std::string& path, std::string subprotocol, uint64_t max_message_bytes,
    std::function<void(std::unique_ptr<http::MessageTransport>)> accepted) {
  if (!impl_->web_port) {
    return makeError(Errc::unsupported, "the hub has no web port (server.web, docs/config.md)");
  }
  return impl_->web_port->serve(
      path, WebPort::Endpoint{std::move(subprotocol), max_message_bytes, std::move(accepted)});
}

void FlowServer::unserveWebSocket(const std::string& path) noexcept {
  if (impl_->web_port) impl_->web_port->unserve(path);
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
