// SPDX-License-Identifier: Apache-2.0
// Listeners on local:, tcp: and tls: addresses (skrobot/runtime/flow/transport.h).
#include "stream_transport.h"
#include "tls_transport.h"

#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>

namespace skr::flow::transport {
namespace {

class StreamListener final : public Listener {
 public:
  StreamListener(Loop& loop, const Address& address, ListenOptions options, Accepted accepted)
      : loop_(loop),
        address_(address),
        options_(std::move(options)),
        accepted_(std::move(accepted)),
        h_(new Handle) {
    h_->owner = this;
    if (address_.kind == Address::Kind::local) {
      uv_pipe_init(loop.uv(), &h_->u.pipe, 0);
      h_->u.pipe.data = h_;
    } else {
      uv_tcp_init(loop.uv(), &h_->u.tcp);
      h_->u.tcp.data = h_;
    }
  }

  ~StreamListener() override {
    h_->owner = nullptr;
    uv_close(reinterpret_cast<uv_handle_t*>(&h_->u),
             [](uv_handle_t* h) { delete static_cast<Handle*>(h->data); });
    if (bound_path_) ::unlink(address_.path.c_str());
  }
  StreamListener(const StreamListener&) = delete;
  StreamListener& operator=(const StreamListener&) = delete;
  StreamListener(StreamListener&&) = delete;
  StreamListener& operator=(StreamListener&&) = delete;

  Result<void> listen() {
    int rc = 0;
    std::string where;
    if (address_.kind == Address::Kind::local) {
      where = address_.path;
      if (auto r = removeStaleSocket(); !r) return r;
      rc = uv_pipe_bind(&h_->u.pipe, address_.path.c_str());
      bound_path_ = rc == 0;
    } else {
      where = "TCP " + address_.host + ":" + std::to_string(address_.port);
      sockaddr_storage addr{};
      rc = uv_ip4_addr(address_.host.c_str(), address_.port, reinterpret_cast<sockaddr_in*>(&addr));
      if (rc != 0) {
        rc = uv_ip6_addr(address_.host.c_str(), address_.port,
                         reinterpret_cast<sockaddr_in6*>(&addr));
      }
      if (rc != 0) return makeError(Errc::invalid_argument, "bad TCP address " + address_.host);
      rc = uv_tcp_bind(&h_->u.tcp, reinterpret_cast<sockaddr*>(&addr), 0);
    }
    if (rc == 0) {
      rc = uv_listen(reinterpret_cast<uv_stream_t*>(&h_->u), options_.backlog,
                     [](uv_stream_t* l, int status) {
                       auto* self = static_cast<Handle*>(l->data)->owner;
                       if (status == 0 && self != nullptr) self->accept();
                     });
    }
    if (rc != 0)
      return makeError(Errc::io_error, "cannot listen on " + where + ": " + uv_strerror(rc));
    if (address_.kind == Address::Kind::local) {
      ::chmod(address_.path.c_str(), options_.socket_mode);
    } else {
      sockaddr_storage bound{};
      int len = sizeof bound;
      uv_tcp_getsockname(&h_->u.tcp, reinterpret_cast<sockaddr*>(&bound), &len);
      port_ = ntohs(reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
    }
    return {};
  }

  [[nodiscard]] uint16_t port() const noexcept override { return port_; }

 private:
  struct Handle {
    union {
      uv_tcp_t tcp;
      uv_pipe_t pipe;
    } u{};
    StreamListener* owner = nullptr;
  };

  // A socket file left by a process that crashed would make bind fail: removed, but only if
  // nobody answers on it (two hubs with the same app name must not steal each other's socket).
  Result<void> removeStaleSocket() {
    const std::string& path = address_.path;
    struct stat st {};
    if (lstat(path.c_str(), &st) != 0) return {};
    if (!S_ISSOCK(st.st_mode)) {
      return makeError(Errc::already_exists, path + " exists and is not a socket");
    }
    const int probe = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
    const bool live = ::connect(probe, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    ::close(probe);
    if (live) return makeError(Errc::already_exists, "another hub listens on " + path);
    ::unlink(path.c_str());
    return {};
  }

  void accept() {
    const bool local = address_.kind == Address::Kind::local;
    auto stream = std::make_unique<StreamTransport>(
        loop_, local ? TransportKind::unix_socket : TransportKind::tcp);
    if (uv_accept(reinterpret_cast<uv_stream_t*>(&h_->u), stream->stream()) != 0) return;
    if (local) {
      accepted_(std::move(stream));
      return;
    }
    uv_tcp_nodelay(reinterpret_cast<uv_tcp_t*>(stream->stream()), 1);
    if (address_.kind == Address::Kind::tcp) {
      stream->refuseTlsPeers();
      accepted_(std::move(stream));
      return;
    }
    auto session = TlsSession::open(*options_.tls);
    if (!session) {
      // Never serve plain bytes on the TLS port: the connection closes with `stream`.
      log::error("flow", "FLOW-TLS", session.error().message);
      return;
    }
    accepted_(std::make_unique<TlsTransport>(loop_, std::move(stream), std::move(session).value(),
                                             true, options_.plain_peer_reply));
  }

  Loop& loop_;
  Address address_;
  ListenOptions options_;
  Accepted accepted_;
  Handle* h_;
  uint16_t port_ = 0;
  bool bound_path_ = false;
};

}  // namespace

Result<std::unique_ptr<Listener>> Listener::open(Loop& loop, const Address& address,
                                                 ListenOptions options, Accepted accepted) {
  if (address.kind == Address::Kind::tls && !options.tls) {
    return makeError(Errc::invalid_argument, "a tls: listener needs its TLS context");
  }
  if (address.kind == Address::Kind::serial || address.kind == Address::Kind::udp) {
    return makeError(Errc::invalid_argument,
                     "serial: and udp: are the hub's server.serial and server.udp, not listeners "
                     "of an address");
  }
  if (address.kind == Address::Kind::ws || address.kind == Address::Kind::wss) {
    // A WebSocket server reads each connection's HTTP request first (the hub's web port):
    // listen on tcp: or tls: and upgrade with http::upgrade() (runtime/internal/http_head.h).
    return makeError(Errc::invalid_argument,
                     "ws: and wss: are the hub's server.web, not listeners of an address");
  }
  auto listener =
      std::make_unique<StreamListener>(loop, address, std::move(options), std::move(accepted));
  if (auto r = listener->listen(); !r) return r.error();
  return std::unique_ptr<Listener>(std::move(listener));
}

}  // namespace skr::flow::transport
