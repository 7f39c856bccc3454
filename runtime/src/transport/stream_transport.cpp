// SPDX-License-Identifier: Apache-2.0
#include "stream_transport.h"

#include "tls_transport.h"

#include <skrobot/runtime/loop.h>

#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <utility>
#include <vector>

namespace skr::flow::transport {
namespace {

Error uvError(const char* what, int rc) {
  return makeError(Errc::io_error, std::string(what) + ": " + uv_strerror(rc));
}

// The buffers as libuv takes them: on the stack for the usual few.
class UvBuffers {
 public:
  explicit UvBuffers(std::span<const std::string_view> buffers) {
    uv_buf_t* out = buffers.size() <= small_.size()
                        ? small_.data()
                        : (large_.resize(buffers.size()), large_.data());
    for (size_t i = 0; i < buffers.size(); ++i) {
      out[i] = uv_buf_init(const_cast<char*>(buffers[i].data()),
                           static_cast<unsigned>(buffers[i].size()));
    }
    data_ = out;
    count_ = static_cast<unsigned>(buffers.size());
  }
  [[nodiscard]] const uv_buf_t* data() const noexcept { return data_; }
  [[nodiscard]] unsigned count() const noexcept { return count_; }

 private:
  std::array<uv_buf_t, 8> small_{};
  std::vector<uv_buf_t> large_;
  const uv_buf_t* data_ = nullptr;
  unsigned count_ = 0;
};

}  // namespace

struct StreamTransport::Handle {
  union {
    uv_tcp_t tcp;
    uv_pipe_t pipe;
  } u{};
  uv_write_t write{};
  uv_connect_t connect{};
  StreamTransport* owner = nullptr;  // null once the transport is gone
  std::function<void(int)> connected;

  uv_handle_t* handle() noexcept { return reinterpret_cast<uv_handle_t*>(&u); }
  uv_stream_t* stream() noexcept { return reinterpret_cast<uv_stream_t*>(&u); }
};

StreamTransport::StreamTransport(Loop& loop, TransportKind kind) : h_(new Handle), kind_(kind) {
  if (kind == TransportKind::tcp) {
    uv_tcp_init(loop.uv(), &h_->u.tcp);
  } else {
    uv_pipe_init(loop.uv(), &h_->u.pipe, 0);
  }
  h_->owner = this;
  h_->handle()->data = h_;
  h_->write.data = h_;
  h_->connect.data = h_;
}

StreamTransport::~StreamTransport() {
  if (h_ == nullptr) return;
  h_->owner = nullptr;  // a write, connect or close callback still to come finds nobody
  if (!closing_) {
    uv_close(h_->handle(), [](uv_handle_t* h) { delete static_cast<Handle*>(h->data); });
  }
}

uv_stream_t* StreamTransport::stream() noexcept {
  return h_->stream();
}

void StreamTransport::connect(const sockaddr* addr, std::function<void(int)> done) {
  h_->connected = std::move(done);
  uv_tcp_nodelay(&h_->u.tcp, 1);
  const auto cb = [](uv_connect_t* req, int status) {
    auto* h = static_cast<Handle*>(req->data);
    if (h->owner != nullptr) h->connected(status);
  };
  if (int rc = uv_tcp_connect(&h_->connect, &h_->u.tcp, addr, cb); rc < 0) {
    // Told at once; the dialer reports its outcome from the loop.
    h_->connected(rc);
  }
}

void StreamTransport::connect(const std::string& path, std::function<void(int)> done) {
  h_->connected = std::move(done);
  uv_pipe_connect(&h_->connect, &h_->u.pipe, path.c_str(), [](uv_connect_t* req, int status) {
    auto* h = static_cast<Handle*>(req->data);
    if (h->owner != nullptr) h->connected(status);
  });
}

Result<void> StreamTransport::start(Receiver& receiver) {
  rx_ = &receiver;
  return resume();
}

void StreamTransport::pause() noexcept {
  if (reading_) uv_read_stop(h_->stream());
  reading_ = false;
}

Result<void> StreamTransport::resume() {
  if (reading_ || closing_ || ended_ || rx_ == nullptr) return {};
  if (int rc = uv_read_start(h_->stream(), &onAlloc, &onRead); rc < 0) return uvError("read", rc);
  reading_ = true;
  return {};
}

void StreamTransport::onAlloc(uv_handle_t* h, size_t, uv_buf_t* buf) {
  auto* self = static_cast<Handle*>(h->data)->owner;
  const std::span<char> room = self->rx_->readBuffer();
  *buf = uv_buf_init(room.data(), static_cast<unsigned>(room.size()));
}

void StreamTransport::onRead(uv_stream_t* s, ssize_t nread, const uv_buf_t* buf) {
  auto* self = static_cast<Handle*>(s->data)->owner;
  if (nread == 0 || self == nullptr || self->closing_) return;
  if (nread < 0) {
    self->pause();
    self->ended_ = true;
    if (nread == UV_EOF) {
      self->rx_->ended({TransportEnd::Why::peer_closed, "peer closed the connection"});
    } else {
      self->rx_->ended({TransportEnd::Why::error, uv_strerror(static_cast<int>(nread))});
    }
    return;
  }
  if (self->check_tls_) {
    self->check_tls_ = false;
    if (looksLikeTls(std::string_view(buf->base, static_cast<size_t>(nread)))) {
      self->pause();
      self->ended_ = true;
      self->rx_->ended({TransportEnd::Why::refused,
                        "a TLS client on the plain TCP port (the hub has no server.tls; the "
                        "client should use a tcp: address)"});
      return;
    }
  }
  self->rx_->received(static_cast<size_t>(nread));
}

Result<size_t> StreamTransport::tryWrite(std::span<const std::string_view> buffers) {
  if (closing_) return makeError(Errc::io_error, "closed");
  const UvBuffers bufs(buffers);
  const int sent = uv_try_write(h_->stream(), bufs.data(), bufs.count());
  if (sent == UV_EAGAIN) return size_t{0};
  if (sent < 0) return uvError("write", sent);
  return static_cast<size_t>(sent);
}

Result<void> StreamTransport::write(std::span<const std::string_view> buffers) {
  if (closing_) return makeError(Errc::io_error, "closed");
  const UvBuffers bufs(buffers);  // libuv copies the array, not the bytes
  const auto cb = [](uv_write_t* req, int status) {
    auto* self = static_cast<Handle*>(req->data)->owner;
    if (self == nullptr || self->closing_) return;  // cancelled by close
    self->writing_ = false;
    if (status < 0) {
      self->rx_->written(uvError("write", status));
    } else {
      self->rx_->written({});
    }
  };
  if (int rc = uv_write(&h_->write, h_->stream(), bufs.data(), bufs.count(), cb); rc < 0) {
    return uvError("write", rc);
  }
  writing_ = true;
  return {};
}

Result<Detached> StreamTransport::detach() {
  if (closing_ || h_ == nullptr) return makeError(Errc::closed, "closed");
  if (writing_) return makeError(Errc::invalid_argument, "a write is under way");
  pause();
  const int own = descriptor();
  const int fd = own >= 0 ? ::fcntl(own, F_DUPFD_CLOEXEC, 0) : -1;
  if (fd < 0) return makeError(Errc::io_error, std::string("dup: ") + std::strerror(errno));
  Detached out(kind_, fd, peer());
  // Closed here without a callback: the connection lives on in `fd`.
  rx_ = nullptr;
  closing_ = true;
  h_->owner = nullptr;
  uv_close(h_->handle(), [](uv_handle_t* h) { delete static_cast<Handle*>(h->data); });
  h_ = nullptr;
  return out;
}

Result<void> StreamTransport::open(int fd) {
  const int rc =
      kind_ == TransportKind::tcp ? uv_tcp_open(&h_->u.tcp, fd) : uv_pipe_open(&h_->u.pipe, fd);
  if (rc < 0) return uvError("adopt", rc);
  if (kind_ == TransportKind::tcp) uv_tcp_nodelay(&h_->u.tcp, 1);
  return {};
}

Detached::~Detached() {
  if (fd_ >= 0) ::close(fd_);
}

Detached::Detached(Detached&& other) noexcept
    : kind_(other.kind_),
      fd_(std::exchange(other.fd_, -1)),
      peer_(std::move(other.peer_)),
      tls_(std::move(other.tls_)),
      tls_server_(other.tls_server_) {}

Detached& Detached::operator=(Detached&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    kind_ = other.kind_;
    fd_ = std::exchange(other.fd_, -1);
    peer_ = std::move(other.peer_);
    tls_ = std::move(other.tls_);
    tls_server_ = other.tls_server_;
  }
  return *this;
}

int Detached::release() noexcept {
  return std::exchange(fd_, -1);
}

Result<std::unique_ptr<Transport>> adopt(Loop& loop, Detached detached) {
  const TransportKind kind = detached.kind();
  const bool tls = kind == TransportKind::tls && detached.tlsSession().has_value();
  if (kind != TransportKind::unix_socket && kind != TransportKind::tcp && !tls) {
    return makeError(Errc::unsupported,
                     std::string(transportKindName(kind)) + " connections cannot be adopted");
  }
  auto t = std::make_unique<StreamTransport>(loop, tls ? TransportKind::tcp : kind);
  if (auto r = t->open(detached.descriptor()); !r) return r.error();  // `detached` closes it
  (void)detached.release();
  if (!tls) return std::unique_ptr<Transport>(std::move(t));
  return std::unique_ptr<Transport>(TlsTransport::adopted(
      loop, std::move(t), std::move(*detached.tlsSession()), detached.tlsServer()));
}

void StreamTransport::close(std::string_view) noexcept {
  if (closing_ || h_ == nullptr) return;
  closing_ = true;
  pause();
  uv_close(h_->handle(), [](uv_handle_t* h) {
    auto* handle = static_cast<Handle*>(h->data);
    StreamTransport* self = handle->owner;
    if (self != nullptr) {
      self->h_ = nullptr;
      handle->owner = nullptr;
      if (self->rx_ != nullptr) self->rx_->closed();  // may destroy `self`
    }
    delete handle;
  });
}

int StreamTransport::descriptor() const noexcept {
  uv_os_fd_t fd = -1;
  if (h_ == nullptr || uv_fileno(h_->handle(), &fd) != 0) return -1;
  return fd;
}

PeerIdentity StreamTransport::peer() const {
  PeerIdentity id;
  id.kind = kind_;
  if (h_ == nullptr) return id;
  if (kind_ == TransportKind::tcp) {
    sockaddr_storage addr{};
    int len = sizeof addr;
    char name[INET6_ADDRSTRLEN] = {};
    if (uv_tcp_getpeername(&h_->u.tcp, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
      if (addr.ss_family == AF_INET6) {
        uv_ip6_name(reinterpret_cast<sockaddr_in6*>(&addr), name, sizeof name);
      } else {
        uv_ip4_name(reinterpret_cast<sockaddr_in*>(&addr), name, sizeof name);
      }
      id.address = name;
    }
    return id;
  }
  ucred cred{};
  socklen_t len = sizeof cred;
  const int fd = descriptor();
  if (fd >= 0 && ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0) id.uid = cred.uid;
  return id;
}

std::string_view transportKindName(TransportKind kind) noexcept {
  switch (kind) {
    case TransportKind::unix_socket:
      return "unix";
    case TransportKind::tcp:
      return "tcp";
    case TransportKind::tls:
      return "tls";
    case TransportKind::memory:
      return "memory";
    case TransportKind::serial:
      return "serial";
    case TransportKind::udp:
      return "udp";
    case TransportKind::websocket:
      return "ws";
  }
  return "?";
}

std::string PeerIdentity::source() const {
  if (kind == TransportKind::unix_socket) {
    return uid >= 0 ? "uid:" + std::to_string(uid) : std::string("unix:?");
  }
  if (kind == TransportKind::serial) return "serial:" + device;
  if (kind == TransportKind::udp) return "udp:" + address;
  if (kind == TransportKind::websocket) return "ws:" + (address.empty() ? "?" : address);
  return address.empty() ? std::string("tcp:?") : "tcp:" + address;
}

}  // namespace skr::flow::transport
