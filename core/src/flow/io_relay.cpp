// SPDX-License-Identifier: Apache-2.0
#include "io_relay.h"

#include "families/blobs/blob_store.h"  // kBulkNice
#include "uv_handle.h"

#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/log.h>

#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>
#include <uv.h>

#include <atomic>
#include <deque>
#include <optional>
#include <vector>

namespace skr::flow {

// What the two ends of a moved connection share: the socket's transport and its frame splitting
// (I/O thread), and the inbox the main loop drains (under the mutex).
struct RelayShared final : transport::Transport::Receiver {
  RelayShared(IoThread& thread, uint32_t max_frame_bytes) : io(thread), input(max_frame_bytes) {}

  // --- I/O thread
  IoThread& io;
  std::unique_ptr<transport::Transport> back;
  FrameInput input;
  bool window_paused = false;  // too much waits for the main loop: reading paused
  bool refused = false;        // a frame above the limit: nothing more is read

  // --- the inbox, under the mutex; `wake` (the main loop's) is signalled after each change
  std::mutex mutex;
  uv_async_t* wake = nullptr;  // null once the main end closed it
  std::deque<FrameInput::Block> frames;
  std::vector<Result<void>> written_results;
  std::optional<transport::TransportEnd> end;
  bool back_closed = false;
  std::atomic<size_t> waiting{0};  // bytes of frames the connection did not take yet

  template <class F>
  void tell(F&& change) {
    std::lock_guard lock(mutex);
    change();
    if (wake != nullptr) uv_async_send(wake);
  }

  // I/O thread: the socket moved here.
  void adopt(transport::Detached detached, FrameInput::Block unread) {
    auto t = transport::adopt(io.loop(), std::move(detached));
    if (!t) {
      tell([&] {
        end = transport::TransportEnd{transport::TransportEnd::Why::error, t.error().message};
      });
      tell([&] { back_closed = true; });
      return;
    }
    back = std::move(*t);
    if (back->kind() == transport::TransportKind::unix_socket) {
      // Downloads: the kernel's default send buffer (about 200 KiB) makes a wake-up of each side
      // per 200 KiB. Linux doubles it (and caps it at net.core.wmem_max).
      const int size = 1 << 20;
      if (const int fd = back->descriptor(); fd >= 0) {
        (void)::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &size, sizeof size);
      }
    }
    io.serving.insert(this);
    input.adopt(std::move(unread));
    forward();
    if (auto r = back->start(*this); !r) {
      tell([&] {
        end = transport::TransportEnd{transport::TransportEnd::Why::error, r.error().message};
      });
    }
  }

  // I/O thread: the whole frames received go to the main loop.
  void forward() {
    FrameInput::Block block = input.takeFrames();
    const auto next = input.peek().status;
    if (next == FrameSplitter::Status::too_large || next == FrameSplitter::Status::empty_frame) {
      // The connection reports it, as it would have on the main loop.
      FrameInput::Block rest = input.takeAll();
      refused = true;
      if (back) back->pause();
      tell([&] {
        waiting += block.size() + rest.size();
        if (block.size() > 0) frames.push_back(std::move(block));
        frames.push_back(std::move(rest));
      });
      return;
    }
    input.settle();
    if (block.size() == 0) return;
    const size_t size = block.size();
    tell([&] {
      waiting += size;
      frames.push_back(std::move(block));
    });
    if (waiting.load() > RelayTransport::kWindow && back && !window_paused) {
      window_paused = true;
      back->pause();
    }
  }

  // I/O thread: the main loop took enough.
  void resumeReading() {
    if (!window_paused || refused || !back) return;
    window_paused = false;
    if (auto r = back->resume(); !r) {
      tell([&] {
        end = transport::TransportEnd{transport::TransportEnd::Why::error, r.error().message};
      });
    }
  }

  // I/O thread: the main end closes; the socket goes (a write under way is dropped).
  void closeBack(std::string reason) {
    if (back) {
      back->close(reason);  // closed() follows
    } else {
      tell([&] { back_closed = true; });
    }
  }

  // I/O thread: the thread stops: the socket goes now, without a callback.
  void abandon() {
    back.reset();
    tell([&] { back_closed = true; });
  }

  // Transport::Receiver (I/O thread)
  std::span<char> readBuffer() override { return input.room(); }
  void received(size_t n) override {
    input.commit(n);
    forward();
  }
  void message(std::string_view) override {}  // Unix sockets and TCP are streams
  void written(Result<void> result) override {
    tell([&] { written_results.push_back(std::move(result)); });
  }
  void ended(const transport::TransportEnd& e) override {
    tell([&] {
      if (!end) end = e;
    });
  }
  void closed() noexcept override {
    io.serving.erase(this);
    back.reset();
    tell([&] { back_closed = true; });
  }
};

// --- IoThread -------------------------------------------------------------------------------

IoThread::IoThread(std::string name) : thread_(LoopOptions{.name = std::move(name)}) {
  thread_.start();
  // Below the main loop, as the store's thread: under load the flows' loop is scheduled first.
  thread_.loop().post(
      [] { (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), kBulkNice); });
}

IoThread::~IoThread() {
  stop();
}

bool IoThread::post(std::function<void()> fn) {
  std::lock_guard lock(mutex_);
  if (stopped_) return false;
  thread_.loop().post(std::move(fn));
  return true;
}

void IoThread::stop() noexcept {
  {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
  }
  // What was posted before runs first (the closes asked by connections that went), then every
  // socket still here goes.
  thread_.loop().invoke([this] {
    for (RelayShared* s : std::set<RelayShared*>(serving)) s->abandon();
    serving.clear();
  });
  {
    std::lock_guard lock(mutex_);
    stopped_ = true;
  }
  thread_.stop();
}

// --- RelayTransport -------------------------------------------------------------------------

RelayTransport::RelayTransport(Loop& main, std::shared_ptr<IoThread> io,
                               transport::Detached detached, FrameInput::Block unread,
                               uint32_t max_frame_bytes, Frames frames)
    : main_(main),
      io_(std::move(io)),
      shared_(std::make_shared<RelayShared>(*io_, max_frame_bytes)),
      kind_(detached.kind()),
      peer_(detached.peer()),
      frames_(std::move(frames)) {
  shared_->wake = newUvHandle<uv_async_t>(this);
  uv_async_init(main_.uv(), shared_->wake, &RelayTransport::onWake);
  auto d = std::make_shared<transport::Detached>(std::move(detached));
  auto u = std::make_shared<FrameInput::Block>(std::move(unread));
  if (!io_->post([s = shared_, d, u] { s->adopt(std::move(*d), std::move(*u)); })) {
    shared_->end = transport::TransportEnd{transport::TransportEnd::Why::error, "the hub stops"};
    shared_->back_closed = true;
  }
}

RelayTransport::~RelayTransport() {
  uv_async_t* wake = nullptr;
  {
    std::lock_guard lock(shared_->mutex);
    std::swap(wake, shared_->wake);
  }
  if (wake != nullptr) {
    wake->data = nullptr;
    closeUvHandle(wake);
  }
  if (!closed_) (void)io_->post([s = shared_] { s->abandon(); });
}

Result<void> RelayTransport::start(Receiver& receiver) {
  receiver_ = &receiver;
  paused_ = false;
  uv_async_send(shared_->wake);  // what already arrived
  return {};
}

void RelayTransport::pause() noexcept {
  paused_ = true;
}

Result<void> RelayTransport::resume() {
  paused_ = false;
  std::lock_guard lock(shared_->mutex);
  if (shared_->wake != nullptr) uv_async_send(shared_->wake);  // delivered from the loop
  return {};
}

Result<size_t> RelayTransport::tryWrite(std::span<const std::string_view>) {
  if (closing_) return makeError(Errc::io_error, "closed");
  return size_t{0};
}

Result<void> RelayTransport::write(std::span<const std::string_view> buffers) {
  if (closing_) return makeError(Errc::io_error, "closed");
  // The views stay valid until written(): the I/O thread writes from them.
  std::vector<std::string_view> views(buffers.begin(), buffers.end());
  if (!io_->post([s = shared_, views = std::move(views)] {
        Result<void> r = makeError(Errc::io_error, "the connection is closed");
        if (s->back) r = s->back->write(views);
        if (!r) s->written(std::move(r));
      })) {
    return makeError(Errc::io_error, "the hub stops");
  }
  return {};
}

void RelayTransport::close(std::string_view reason) noexcept {
  if (closing_) return;
  closing_ = true;
  if (!io_->post([s = shared_, reason = std::string(reason)] { s->closeBack(reason); })) {
    shared_->tell([&] { shared_->back_closed = true; });
  }
}

void RelayTransport::onWake(uv_async_s* handle) {
  if (auto* self = static_cast<RelayTransport*>(handle->data)) self->drain();
}

void RelayTransport::drain() {
  if (receiver_ == nullptr || closed_) return;
  std::vector<Result<void>> written;
  std::optional<transport::TransportEnd> end;
  bool back_closed = false;
  std::deque<FrameInput::Block> frames;
  {
    std::lock_guard lock(shared_->mutex);
    written.swap(shared_->written_results);
    end = shared_->end;
    back_closed = shared_->back_closed;
    if (!paused_ && !closing_) frames.swap(shared_->frames);
  }
  for (auto& r : written) {
    if (closing_) break;
    receiver_->written(std::move(r));
  }
  while (!frames.empty() && !paused_ && !closing_) {
    FrameInput::Block block = std::move(frames.front());
    frames.pop_front();
    const size_t size = block.size();
    const size_t before = shared_->waiting.fetch_sub(size);
    frames_(std::move(block));
    if (before > kWindow / 2 && before - size <= kWindow / 2) {
      (void)io_->post([s = shared_] { s->resumeReading(); });
    }
  }
  if (!frames.empty()) {
    // Paused meanwhile: the rest goes back in front of what came since.
    std::lock_guard lock(shared_->mutex);
    for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
      shared_->frames.push_front(std::move(*it));
    }
  }
  bool more = false;
  {
    std::lock_guard lock(shared_->mutex);
    more = !shared_->frames.empty();
  }
  if (end && !more && !closing_ && !paused_) {
    {
      std::lock_guard lock(shared_->mutex);
      shared_->end.reset();
    }
    receiver_->ended(*end);  // the receiver closes
  }
  if (closing_ && back_closed) closeNow();
}

void RelayTransport::closeNow() noexcept {
  if (closed_) return;
  closed_ = true;
  uv_async_t* wake = nullptr;
  {
    std::lock_guard lock(shared_->mutex);
    std::swap(wake, shared_->wake);
  }
  if (wake == nullptr) return;
  uv_close(reinterpret_cast<uv_handle_t*>(wake), [](uv_handle_t* h) {
    auto* self = static_cast<RelayTransport*>(h->data);
    delete reinterpret_cast<uv_async_t*>(h);
    if (self != nullptr && self->receiver_ != nullptr) self->receiver_->closed();
  });
}

}  // namespace skr::flow
