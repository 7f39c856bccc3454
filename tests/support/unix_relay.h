// SPDX-License-Identifier: Apache-2.0
// A Unix-socket relay on a Loop, for tests that cut a connection and let it come back: what
// connects to `path` is joined to `target` (connected anew for each), byte for byte. cut()
// closes every connection it joined, and holds those that come next, unanswered, as a network
// that lost its way would, until restore(). Loop thread only; header-only.
#pragma once

#include <skrobot/runtime/loop.h>

#include <uv.h>

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace skr::test {

class UnixRelay {
 public:
  UnixRelay(Loop& loop, std::string path, std::string target)
      : loop_(loop), path_(std::move(path)), target_(std::move(target)) {}
  ~UnixRelay() {
    closeAll();
    if (listener_ != nullptr) {
      listener_->data = nullptr;  // not a Conn
      closeHandle(listener_);
      ::unlink(path_.c_str());
    }
  }
  UnixRelay(const UnixRelay&) = delete;
  UnixRelay& operator=(const UnixRelay&) = delete;
  UnixRelay(UnixRelay&&) = delete;
  UnixRelay& operator=(UnixRelay&&) = delete;

  // Listens at `path`. False when it cannot.
  bool open() {
    if (listener_ != nullptr) return true;
    ::unlink(path_.c_str());
    auto* l = newPipe(nullptr);
    l->data = this;
    if (uv_pipe_bind(l, path_.c_str()) != 0 ||
        uv_listen(reinterpret_cast<uv_stream_t*>(l), 64, &UnixRelay::onConnection) != 0) {
      l->data = nullptr;
      closeHandle(l);
      return false;
    }
    listener_ = l;
    return true;
  }

  // Closes every connection, both sides; those that come next are held until restore().
  void cut() {
    holding_ = true;
    closeAll();
  }
  // Joins the connections held since cut() to the target, and the next ones as they come.
  void restore() {
    holding_ = false;
    for (Conn* c : std::vector<Conn*>(conns_)) {
      if (!c->joined) join(c);
    }
  }

  // Handles of every relay not freed yet: run the loop until 0 before destroying it.
  static int& liveHandles() {
    static int n = 0;
    return n;
  }

 private:
  struct Conn {
    UnixRelay* relay = nullptr;
    uv_pipe_t* side[2] = {nullptr, nullptr};  // the one that connected, the target
    int handles = 2;
    bool closing = false;
    bool joined = false;  // connecting to the target, or connected
  };
  struct Write {
    uv_write_t req;
    std::unique_ptr<char[]> data;
  };

  uv_pipe_t* newPipe(Conn* c) {
    auto* p = new uv_pipe_t;
    uv_pipe_init(loop_.uv(), p, 0);
    p->data = c;
    ++liveHandles();
    return p;
  }
  static void closeHandle(uv_pipe_t* p) {
    uv_close(reinterpret_cast<uv_handle_t*>(p), [](uv_handle_t* h) {
      auto* pipe = reinterpret_cast<uv_pipe_t*>(h);
      --liveHandles();
      if (auto* c = static_cast<Conn*>(pipe->data); c != nullptr && --c->handles == 0) delete c;
      delete pipe;
    });
  }
  void closeAll() {
    for (Conn* c : std::exchange(conns_, {})) {
      c->relay = nullptr;
      close(c);
    }
  }
  static void close(Conn* c) {
    if (c->closing) return;
    c->closing = true;
    if (c->relay != nullptr) std::erase(c->relay->conns_, c);
    for (uv_pipe_t* p : c->side) closeHandle(p);
  }

  static void onConnection(uv_stream_t* server, int status) {
    auto* self = static_cast<UnixRelay*>(server->data);
    if (status != 0) return;
    auto* c = new Conn;
    c->relay = self;
    c->side[0] = self->newPipe(c);
    c->side[1] = self->newPipe(c);
    self->conns_.push_back(c);
    if (uv_accept(server, reinterpret_cast<uv_stream_t*>(c->side[0])) != 0) return close(c);
    if (!self->holding_) self->join(c);
  }
  void join(Conn* c) {
    c->joined = true;
    auto* req = new uv_connect_t;
    req->data = c;
    uv_pipe_connect(req, c->side[1], target_.c_str(), [](uv_connect_t* r, int st) {
      auto* conn = static_cast<Conn*>(r->data);
      delete r;
      if (conn->closing) return;
      if (st != 0) return close(conn);
      for (uv_pipe_t* p : conn->side) {
        uv_read_start(reinterpret_cast<uv_stream_t*>(p), &UnixRelay::onAlloc, &UnixRelay::onRead);
      }
    });
  }
  static void onAlloc(uv_handle_t*, size_t suggested, uv_buf_t* buf) {
    buf->base = new char[suggested];
    buf->len = suggested;
  }
  static void onRead(uv_stream_t* s, ssize_t n, const uv_buf_t* buf) {
    std::unique_ptr<char[]> data(buf->base);
    auto* c = static_cast<Conn*>(s->data);
    if (n == 0 || c->closing) return;
    if (n < 0) return close(c);
    uv_stream_t* to =
        reinterpret_cast<uv_stream_t*>(c->side[c->side[0] == reinterpret_cast<uv_pipe_t*>(s)]);
    auto* w = new Write;
    w->data = std::move(data);
    w->req.data = w;
    const uv_buf_t out = uv_buf_init(w->data.get(), static_cast<unsigned>(n));
    if (uv_write(&w->req, to, &out, 1,
                 [](uv_write_t* r, int) { delete static_cast<Write*>(r->data); }) != 0) {
      delete w;
      close(c);
    }
  }

  Loop& loop_;
  std::string path_, target_;
  uv_pipe_t* listener_ = nullptr;
  bool holding_ = false;
  std::vector<Conn*> conns_;
};

}  // namespace skr::test
