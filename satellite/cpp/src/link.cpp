// SPDX-License-Identifier: Apache-2.0
#include "link.h"

#include <algorithm>
#include <csignal>
#include <cstring>
#include <mutex>

namespace skr::sat::detail {
namespace {

constexpr size_t kReadChunk = size_t{64} * 1024;
constexpr size_t kKeepBuffer = 1 << 20;  // shrink buffers above this once they drain

std::string uvError(const char* what, int rc) {
  return std::string(what) + ": " + uv_strerror(rc);
}

}  // namespace

void ignoreSigpipe() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction old {};
    if (::sigaction(SIGPIPE, nullptr, &old) == 0 && (old.sa_flags & SA_SIGINFO) == 0 &&
        old.sa_handler == SIG_DFL) {
      ::signal(SIGPIPE, SIG_IGN);
    }
  });
}

Link::Link(uv_loop_t* loop, const Address& address, const Result<flow::TlsContext>* tls,
           uint32_t max_frame_bytes, Handler& handler)
    : loop_(loop), address_(address), splitter_(max_frame_bytes), handler_(handler) {
  ignoreSigpipe();
  if (address.kind == Address::Kind::tls) {
    if (tls != nullptr) {
      tls_context_ = *tls;
    } else {
      tls_context_ = makeError(Errc::invalid_argument, "TLS: no settings");
    }
  }
}

Link* Link::open(uv_loop_t* loop, const Address& address, const Result<flow::TlsContext>* tls,
                 uint32_t max_frame_bytes, Handler& handler) {
  auto* link = new Link(loop, address, tls, max_frame_bytes, handler);
  link->start();
  return link;
}

void Link::start() {
  uv_idle_init(loop_, &idle_);
  idle_.data = this;
  ++outstanding_;
  connect_req_.data = this;
  write_req_.data = this;
  resolve_req_.data = this;
  if (address_.kind == Address::Kind::local) {
    uv_pipe_init(loop_, &h_.pipe, 0);
    h_.pipe.data = this;
    ++outstanding_;
    state_ = State::connecting;
    uv_pipe_connect(&connect_req_, &h_.pipe, address_.path.c_str(), &Link::onConnect);
    return;
  }
  uv_tcp_init(loop_, &h_.tcp);
  h_.tcp.data = this;
  ++outstanding_;
  if (tls_context_ && !*tls_context_) {
    fail(tls_context_->error().message);
    return;
  }
  state_ = State::resolving;
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  const std::string port = std::to_string(address_.port);
  ++outstanding_;  // the resolve request
  if (int rc = uv_getaddrinfo(loop_, &resolve_req_, &Link::onResolved, address_.host.c_str(),
                              port.c_str(), &hints);
      rc < 0) {
    --outstanding_;
    fail(uvError(("resolve " + address_.host).c_str(), rc));
  }
}

void Link::onResolved(uv_getaddrinfo_t* req, int status, addrinfo* res) {
  auto* self = static_cast<Link*>(req->data);
  if (self->state_ == State::resolving) {
    if (status < 0 || res == nullptr) {
      self->fail(uvError(("resolve " + self->address_.host).c_str(), status));
    } else {
      self->connectTcp(res->ai_addr);
    }
  }
  if (res != nullptr) uv_freeaddrinfo(res);
  self->release();
}

void Link::connectTcp(const sockaddr* addr) {
  state_ = State::connecting;
  uv_tcp_nodelay(&h_.tcp, 1);
  if (int rc = uv_tcp_connect(&connect_req_, &h_.tcp, addr, &Link::onConnect); rc < 0) {
    fail(uvError("connect", rc));
  }
}

void Link::onConnect(uv_connect_t* req, int status) {
  auto* self = static_cast<Link*>(req->data);
  if (self->state_ != State::connecting) return;  // closed or failed meanwhile
  if (status < 0) {
    self->fail(uvError("connect", status));
    return;
  }
  if (self->tls_context_) {
    auto session = flow::TlsSession::open(**self->tls_context_, self->address_.host);
    if (!session) {
      self->fail(session.error().message);
      return;
    }
    self->tls_.emplace(std::move(session).value());
    self->tls_in_ = std::make_unique<char[]>(kReadChunk);
    self->state_ = State::handshaking;
  } else {
    self->state_ = State::open;
  }
  if (int rc = uv_read_start(self->stream(), &Link::onAlloc, &Link::onRead); rc < 0) {
    self->fail(uvError("read", rc));
    return;
  }
  if (self->tls_) {
    self->kick();  // the ClientHello
    return;
  }
  self->handler_.onLinkConnected();
}

void Link::kick() {
  if (!idle_active_ && !writing_) {
    uv_idle_start(&idle_, &Link::onIdle);
    idle_active_ = true;
  }
}

void Link::fail(std::string why, bool protocol) {
  if (state_ == State::failed || state_ == State::closed) return;
  state_ = State::failed;
  failure_ = std::move(why);
  failure_protocol_ = protocol;
  out_.clear();
  uv_read_stop(stream());
  // Report from the idle callback, never from inside the caller's stack (open(), a callback).
  if (!idle_active_) uv_idle_start(&idle_, &Link::onIdle);
  idle_active_ = true;
}

void Link::close() noexcept {
  if (state_ == State::closed) return;
  state_ = State::closed;
  out_.clear();
  closeHandles();
}

void Link::closeHandles() noexcept {
  if (handles_closing_) return;
  handles_closing_ = true;
  uv_read_stop(stream());
  uv_idle_stop(&idle_);
  idle_active_ = false;
  // Pending connect and write requests are cancelled and their callbacks run before these.
  uv_close(reinterpret_cast<uv_handle_t*>(&h_), &Link::onClosed);
  uv_close(reinterpret_cast<uv_handle_t*>(&idle_), &Link::onClosed);
}

void Link::onClosed(uv_handle_t* h) {
  static_cast<Link*>(h->data)->release();
}

void Link::release() {
  if (--outstanding_ == 0) delete this;
}

void Link::queued() {
  if (state_ != State::open) {
    out_.clear();
    return;
  }
  kick();
}

// Runs once per loop iteration while active, before the loop waits for I/O: the place where
// everything queued during the iteration leaves in one write.
void Link::onIdle(uv_idle_t* idle) {
  auto* self = static_cast<Link*>(idle->data);
  uv_idle_stop(idle);
  self->idle_active_ = false;
  if (self->state_ == State::failed) {
    const std::string why = std::move(self->failure_);
    const bool protocol = self->failure_protocol_;
    self->state_ = State::closed;
    self->closeHandles();
    self->handler_.onLinkClosed(why, protocol);  // `self` lives until the close callbacks
    return;
  }
  if ((self->state_ == State::open || self->state_ == State::handshaking) && !self->writing_) {
    self->flush();
  }
}

void Link::flush() {
  if (tls_) {
    if (!out_.empty()) {
      auto w = tls_->write(out_);
      out_.clear();
      if (!w) {
        fail(w.error().message);
        return;
      }
    }
    tls_->takeOutput(out_);
  }
  if (out_.empty()) return;
  inflight_.swap(out_);
  out_.clear();
  uv_buf_t buf = uv_buf_init(inflight_.data(), static_cast<unsigned>(inflight_.size()));
  writing_ = true;
  ++writes_;
  if (int rc = uv_write(&write_req_, stream(), &buf, 1, &Link::onWrite); rc < 0) {
    writing_ = false;
    fail(uvError("write", rc));
  }
}

void Link::onWrite(uv_write_t* req, int status) {
  auto* self = static_cast<Link*>(req->data);
  self->writing_ = false;
  if (self->state_ != State::open && self->state_ != State::handshaking) return;
  if (status < 0) {
    self->fail(uvError("write", status));
    return;
  }
  if (self->inflight_.capacity() > kKeepBuffer) {
    std::string().swap(self->inflight_);
  } else {
    self->inflight_.clear();
  }
  self->flush();  // what was queued while this write was in flight
}

void Link::onAlloc(uv_handle_t* h, size_t, uv_buf_t* buf) {
  auto* c = static_cast<Link*>(h->data);
  if (c->tls_) {
    *buf = uv_buf_init(c->tls_in_.get(), static_cast<unsigned>(kReadChunk));
    return;
  }
  const size_t have = c->rend_ - c->rstart_;
  // Room for the rest of the frame being received (its length was checked by the splitter).
  const size_t want = std::max(kReadChunk, c->rneed_ > have ? c->rneed_ - have : 0);
  if (c->rcap_ - c->rend_ < want) {
    if (c->rstart_ > 0) {
      if (have > 0) std::memmove(c->rbuf_.get(), c->rbuf_.get() + c->rstart_, have);
      c->rstart_ = 0;
      c->rend_ = have;
    }
    if (c->rcap_ - c->rend_ < want) {
      const size_t cap = c->rend_ + want;
      auto bigger = std::make_unique_for_overwrite<char[]>(cap);
      if (have > 0) std::memcpy(bigger.get(), c->rbuf_.get(), have);
      c->rbuf_ = std::move(bigger);
      c->rcap_ = cap;
    }
  }
  *buf = uv_buf_init(c->rbuf_.get() + c->rend_, static_cast<unsigned>(c->rcap_ - c->rend_));
}

void Link::onRead(uv_stream_t* s, ssize_t nread, const uv_buf_t* buf) {
  auto* c = static_cast<Link*>(s->data);
  if (nread == 0 || (c->state_ != State::open && c->state_ != State::handshaking)) return;
  if (nread < 0) {
    if (c->state_ == State::handshaking) {
      c->fail("TLS handshake with " + c->address_.toString() +
              ": the hub closed the connection (is its TCP port plain? then use a tcp: address)");
      return;
    }
    c->fail(nread == UV_EOF ? "the hub closed the connection"
                            : uvError("read", static_cast<int>(nread)));
    return;
  }
  if (c->tls_) {
    c->receiveTls(buf->base, static_cast<size_t>(nread));
    return;
  }
  c->rend_ += static_cast<size_t>(nread);
  c->processInput();
}

void Link::receiveTls(const char* data, size_t n) {
  if (auto r = tls_->receive(std::string_view(data, n)); !r) {
    // Tell the hub why (an alert: unknown CA, bad certificate...), so that its log says it too.
    std::string alert;
    tls_->takeOutput(alert);
    uv_buf_t b = uv_buf_init(alert.data(), static_cast<unsigned>(alert.size()));
    if (!alert.empty() && !writing_) (void)uv_try_write(stream(), &b, 1);
    fail("TLS with " + address_.toString() + ": " + r.error().message);
    return;
  }
  if (tls_->hasOutput()) kick();
  if (state_ == State::handshaking) {
    if (!tls_->established()) return;
    state_ = State::open;
    handler_.onLinkConnected();  // may close() this link
    if (state_ != State::open) return;
  }
  for (;;) {
    const size_t have = rend_ - rstart_;
    if (rcap_ - rend_ < kReadChunk) {
      if (rstart_ > 0) {
        if (have > 0) std::memmove(rbuf_.get(), rbuf_.get() + rstart_, have);
        rstart_ = 0;
        rend_ = have;
      }
      if (rcap_ - rend_ < kReadChunk) {
        auto bigger = std::make_unique<char[]>(rend_ + kReadChunk);
        if (have > 0) std::memcpy(bigger.get(), rbuf_.get(), have);
        rbuf_ = std::move(bigger);
        rcap_ = rend_ + kReadChunk;
      }
    }
    auto got = tls_->read(rbuf_.get() + rend_, rcap_ - rend_);
    if (!got) {
      fail(got.error().code == Errc::closed
               ? std::string("the hub closed the connection")
               : "TLS with " + address_.toString() + ": " + got.error().message);
      return;
    }
    if (*got == 0) break;
    rend_ += *got;
  }
  processInput();
}

void Link::processInput() {
  while (state_ == State::open) {
    const auto n =
        splitter_.next(reinterpret_cast<const uint8_t*>(rbuf_.get()) + rstart_, rend_ - rstart_);
    if (n.status == flow::FrameSplitter::Status::need_more) {
      rneed_ = n.wanted;
      break;
    }
    if (n.status == flow::FrameSplitter::Status::too_large) {
      fail("frame length " + std::to_string(n.announced) + " exceeds the limit of " +
               std::to_string(splitter_.maxFrameBytes()) + " bytes",
           true);
      return;
    }
    if (n.status == flow::FrameSplitter::Status::empty_frame) {
      fail("frame length 0 (a frame holds at least its code)", true);
      return;
    }
    rstart_ += n.consumed;
    rneed_ = 0;
    handler_.onLinkFrame(n.code, n.body);  // may close() this link
  }
  if (rstart_ == rend_) {
    rstart_ = rend_ = 0;
    if (rcap_ > kKeepBuffer) {
      rbuf_.reset();
      rcap_ = 0;
    }
  }
}

}  // namespace skr::sat::detail
