// SPDX-License-Identifier: Apache-2.0
#include "module_web.h"

#include "http_head.h"

#include <skrobot/runtime/log.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <deque>
#include <iterator>
#include <span>
#include <utility>

namespace skr {
namespace {

constexpr size_t kDefaultQueuedBytes = size_t{8} << 20;
constexpr uint16_t kCloseGoingAway = 1001;

// Connection numbers are unique for the hub's life, across modules.
std::atomic<skr_ws_conn> g_next_conn{1};

}  // namespace

class ModuleWebSockets::Peer final : public flow::transport::Transport::Receiver {
 public:
  Peer(ModuleWebSockets& owner, skr_ws_conn id, skr_sub_handle endpoint,
       std::unique_ptr<flow::http::MessageTransport> t, size_t max_queued)
      : owner_(owner), id_(id), endpoint_(endpoint), t_(std::move(t)), max_queued_(max_queued) {}
  ~Peer() = default;
  Peer(const Peer&) = delete;
  Peer& operator=(const Peer&) = delete;
  Peer(Peer&&) = delete;
  Peer& operator=(Peer&&) = delete;

  [[nodiscard]] Result<void> start() { return t_->start(*this); }
  [[nodiscard]] skr_sub_handle endpoint() const noexcept { return endpoint_; }
  [[nodiscard]] std::string source() const { return t_->peer().source(); }
  [[nodiscard]] uint64_t dropped() const noexcept { return dropped_; }

  // Queues a message; over max_queued_ the oldest droppable ones waiting go first, then the
  // oldest others, the newest message last.
  void send(bool text, std::string data, bool droppable) {
    if (closing_) return;
    queued_ += data.size();
    queue_.push_back(Out{text, droppable, std::move(data)});
    while (queued_ > max_queued_ && queue_.size() > 1) {
      auto last = std::prev(queue_.end());
      auto victim = std::find_if(queue_.begin(), last, [](const Out& o) { return o.droppable; });
      if (victim == last && !last->droppable) victim = queue_.begin();
      queued_ -= victim->data.size();
      queue_.erase(victim);
      ++dropped_;
    }
    pump();
  }

  void close(uint16_t code, std::string_view reason) {
    if (closing_) return;
    closing_ = true;
    why_ = "closed by the module (" + std::to_string(code) + " " + std::string(reason) + ")";
    t_->closeWith(code, reason);
  }

  // No more events for the module; the connection closes (1001).
  void drop() {
    silenced_ = true;
    close(kCloseGoingAway, "the module stopped serving this endpoint");
  }
  [[nodiscard]] bool silenced() const noexcept { return silenced_; }

 private:
  struct Out {
    bool text = false;
    bool droppable = true;
    std::string data;
  };

  // Messages framing: readBuffer() and received() are never called.
  std::span<char> readBuffer() override { return {&unused_, 1}; }
  void received(size_t /*n*/) override {}
  void message(std::string_view bytes) override {
    if (closing_ || silenced_) return;
    const auto e = owner_.endpoints_.find(endpoint_);
    if (e == owner_.endpoints_.end() || e->second.events.message == nullptr) return;
    e->second.events.message(e->second.user, id_, t_->textMessage() ? 1 : 0, bytes.data(),
                             bytes.size());
  }
  void written(Result<void> result) override {
    writing_ = false;
    current_ = Out{};
    if (!result) {
      finish(result.error().message);
      return;
    }
    pump();
  }
  void ended(const flow::transport::TransportEnd& end) override { finish(end.message); }
  void closed() noexcept override { owner_.peerClosed(id_, why_); }  // frees this

  void finish(const std::string& why) {
    if (closing_) return;
    closing_ = true;
    why_ = why;
    t_->close(why);
  }

  void pump() {
    if (writing_ || closing_ || queue_.empty()) return;
    current_ = std::move(queue_.front());
    queue_.pop_front();
    queued_ -= current_.data.size();
    writing_ = true;
    if (auto r = t_->writeMessage(current_.text, current_.data); !r) {
      writing_ = false;
      finish(r.error().message);
    }
  }

  ModuleWebSockets& owner_;
  skr_ws_conn id_;
  skr_sub_handle endpoint_;
  std::unique_ptr<flow::http::MessageTransport> t_;
  size_t max_queued_;
  std::deque<Out> queue_;
  size_t queued_ = 0;
  Out current_;  // being written: its bytes stay until written()
  bool writing_ = false;
  bool closing_ = false;
  bool silenced_ = false;
  uint64_t dropped_ = 0;
  std::string why_ = "closed";
  char unused_ = 0;
};

ModuleWebSockets::ModuleWebSockets(flow::FlowServer& server, std::string log_source)
    : server_(server), log_source_(std::move(log_source)) {}

ModuleWebSockets::~ModuleWebSockets() {
  for (const auto& [handle, e] : endpoints_) server_.unserveWebSocket(e.path);
  endpoints_.clear();
  for (auto& [conn, peer] : peers_) peer->drop();
  peers_.clear();  // a transport destroyed closes at once, with no callback
}

skr_status ModuleWebSockets::serve(const char* path, const char* subprotocol,
                                   size_t max_message_bytes, size_t max_queued_bytes,
                                   const skr_ws_events* events, void* user,
                                   skr_sub_handle* handle_out) {
  if (path == nullptr || subprotocol == nullptr || events == nullptr || handle_out == nullptr ||
      max_message_bytes == 0 || events->struct_size < sizeof(uint32_t)) {
    return SKR_ERR_INVALID_ARGUMENT;
  }
  Endpoint e;
  e.path = path;
  std::memcpy(&e.events, events, std::min<size_t>(events->struct_size, sizeof(e.events)));
  e.events.struct_size = sizeof(e.events);
  e.user = user;
  e.max_queued_bytes = max_queued_bytes != 0 ? max_queued_bytes : kDefaultQueuedBytes;
  const skr_sub_handle handle = next_handle_++;
  auto r = server_.serveWebSocket(e.path, subprotocol, max_message_bytes,
                                  [this, handle](std::unique_ptr<flow::http::MessageTransport> t) {
                                    accepted(handle, std::move(t));
                                  });
  if (!r) {
    log::warn(log_source_, "MODULE-WS", "cannot serve " + e.path + ": " + r.error().message);
    return r.error().code == Errc::unsupported ? SKR_ERR_UNSUPPORTED : SKR_ERR_INVALID_ARGUMENT;
  }
  log::info(log_source_, "MODULE-WS",
            "serves " + e.path + " (" + subprotocol +
                ") on the web port :" + std::to_string(server_.webPort()));
  endpoints_.emplace(handle, std::move(e));
  *handle_out = handle;
  return SKR_OK;
}

skr_status ModuleWebSockets::unserve(skr_sub_handle handle) {
  const auto e = endpoints_.find(handle);
  if (e == endpoints_.end()) return SKR_ERR_NOT_FOUND;
  server_.unserveWebSocket(e->second.path);
  endpoints_.erase(e);
  dropPeers(handle);
  return SKR_OK;
}

void ModuleWebSockets::dropPeers(skr_sub_handle endpoint) {
  for (auto& [conn, peer] : peers_) {
    if (peer->endpoint() == endpoint) peer->drop();  // freed once closed
  }
}

skr_status ModuleWebSockets::send(skr_ws_conn conn, bool text, const void* data, size_t size,
                                  bool droppable) {
  const auto p = peers_.find(conn);
  if (p == peers_.end() || p->second->silenced()) return SKR_ERR_NOT_FOUND;
  if (data == nullptr && size != 0) return SKR_ERR_INVALID_ARGUMENT;
  p->second->send(text, std::string(static_cast<const char*>(data), size), droppable);
  return SKR_OK;
}

skr_status ModuleWebSockets::close(skr_ws_conn conn, uint16_t code, const char* reason) {
  const auto p = peers_.find(conn);
  if (p == peers_.end() || p->second->silenced()) return SKR_ERR_NOT_FOUND;
  // The codes an endpoint may send (RFC 6455 7.4.1): not 1004-1006 or 1012 and up (reserved).
  const bool sendable = (code >= 1000 && code <= 1003) || (code >= 1007 && code <= 1011) ||
                        (code >= 3000 && code <= 4999);
  if (!sendable) return SKR_ERR_INVALID_ARGUMENT;
  p->second->close(code, reason != nullptr ? reason : "");
  return SKR_OK;
}

void ModuleWebSockets::accepted(skr_sub_handle endpoint,
                                std::unique_ptr<flow::http::MessageTransport> t) {
  const auto e = endpoints_.find(endpoint);
  if (e == endpoints_.end()) return;  // unserved meanwhile: the transport closes
  const skr_ws_conn conn = g_next_conn.fetch_add(1);
  auto peer =
      std::make_unique<Peer>(*this, conn, endpoint, std::move(t), e->second.max_queued_bytes);
  Peer& p = *peer;
  peers_.emplace(conn, std::move(peer));
  if (auto r = p.start(); !r) {
    log::info(log_source_, "MODULE-WS", e->second.path + ": " + r.error().message);
    peers_.erase(conn);
    return;
  }
  if (e->second.events.opened != nullptr) {
    e->second.events.opened(e->second.user, conn, p.source().c_str());
  }
}

void ModuleWebSockets::peerClosed(skr_ws_conn conn, const std::string& why) {
  const auto p = peers_.find(conn);
  if (p == peers_.end()) return;
  std::unique_ptr<Peer> peer = std::move(p->second);
  peers_.erase(p);
  if (peer->dropped() != 0) {
    log::info(log_source_, "MODULE-WS",
              "connection " + std::to_string(conn) + ": " + std::to_string(peer->dropped()) +
                  " messages dropped for a slow client");
  }
  if (peer->silenced()) return;
  const auto e = endpoints_.find(peer->endpoint());
  if (e != endpoints_.end() && e->second.events.closed != nullptr) {
    e->second.events.closed(e->second.user, conn, why.c_str());
  }
}

}  // namespace skr
