// SPDX-License-Identifier: Apache-2.0
#include "link.h"

#include <skrobot/runtime/loop.h>

#include <csignal>
#include <cstring>
#include <mutex>

namespace skr::sat::detail {
namespace {

namespace transport = flow::transport;

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

Link::Link(Loop& loop, const Address& address, uint32_t max_frame_bytes, Handler& handler)
    : loop_(loop),
      address_(address),
      handler_(handler),
      input_(max_frame_bytes),
      turn_(loop, [this] { flush(); }) {
  ignoreSigpipe();
}

Link* Link::open(Loop& loop, const Address& address, const transport::DialOptions& dial,
                 uint32_t max_frame_bytes, Handler& handler) {
  auto* link = new Link(loop, address, max_frame_bytes, handler);
  link->dialer_ =
      transport::Dialer::open(loop, address, dial, [link](auto t) { link->opened(std::move(t)); });
  return link;
}

void Link::opened(Result<std::unique_ptr<transport::Transport>> t) {
  // From the dialer's callback: the dialer, done, goes with this link.
  if (state_ != State::connecting) return;
  if (!t) {
    fail(t.error().message);
    return;
  }
  transport_ = std::move(t).value();
  if (auto r = transport_->start(*this); !r) {
    fail(r.error().message);
    return;
  }
  state_ = State::open;
  handler_.onLinkConnected();  // may close() this link
}

void Link::fail(std::string why, bool protocol) {
  if (state_ == State::failed || state_ == State::closed) return;
  state_ = State::failed;
  failure_ = std::move(why);
  failure_protocol_ = protocol;
  out_.clear();
  if (transport_) transport_->pause();
  // Reported at the loop's next turn, never from inside the caller's stack (a handler's call).
  turn_.startIn(0);
}

void Link::close() noexcept {
  if (state_ == State::closed) return;
  state_ = State::closed;
  out_.clear();
  turn_.stop();
  if (transport_) {
    transport_->close("closed by the satellite");  // closed() deletes this
  } else {
    delete this;  // still dialling: the dialer stops with it
  }
}

void Link::queued() {
  if (state_ != State::open) {
    out_.clear();
    return;
  }
  if (!writing_ && !turn_.active()) turn_.startIn(0);
}

// At the loop's turn after frames were queued: everything queued meanwhile leaves in one write.
void Link::flush() {
  if (state_ == State::failed) {
    const std::string why = std::move(failure_);
    const bool protocol = failure_protocol_;
    state_ = State::closed;
    handler_.onLinkClosed(why, protocol);
    if (transport_) {
      transport_->close(why);  // closed() deletes this
    } else {
      delete this;
    }
    return;
  }
  if (state_ != State::open || writing_ || out_.empty()) return;
  inflight_.swap(out_);
  out_.clear();
  writing_ = true;
  ++writes_;
  const std::string_view bytes = inflight_;
  if (auto r = transport_->write({&bytes, 1}); !r) {
    writing_ = false;
    fail(r.error().message);
  }
}

void Link::written(Result<void> result) {
  writing_ = false;
  if (state_ != State::open) return;
  if (!result) {
    fail(result.error().message);
    return;
  }
  if (inflight_.capacity() > flow::FrameInput::kKeepBuffer) {
    std::string().swap(inflight_);
  } else {
    inflight_.clear();
  }
  flush();  // what was queued while this write was in flight
}

void Link::ended(const transport::TransportEnd& end) {
  switch (end.why) {
    case transport::TransportEnd::Why::peer_closed:
      fail("the hub closed the connection");
      break;
    case transport::TransportEnd::Why::refused:
      fail("TLS with " + address_.toString() + ": " + end.message);
      break;
    case transport::TransportEnd::Why::error:
      fail(end.message);
      break;
  }
}

void Link::received(size_t n) {
  input_.commit(n);
  processInput();
}

void Link::message(std::string_view bytes) {
  uint32_t length = 0;
  if (bytes.size() >= 4) std::memcpy(&length, bytes.data(), 4);
  if (bytes.size() < 5 || length + size_t{4} != bytes.size()) {
    fail("a message of " + std::to_string(bytes.size()) + " bytes is not one frame", true);
    return;
  }
  input_.append(bytes);
  processInput();
}

void Link::processInput() {
  while (state_ == State::open) {
    const auto n = input_.peek();
    if (n.status == flow::FrameSplitter::Status::need_more) break;
    if (n.status == flow::FrameSplitter::Status::too_large) {
      fail("frame length " + std::to_string(n.announced) + " exceeds the limit of " +
               std::to_string(input_.splitter().maxFrameBytes()) + " bytes",
           true);
      return;
    }
    if (n.status == flow::FrameSplitter::Status::empty_frame) {
      fail("frame length 0 (a frame holds at least its code)", true);
      return;
    }
    input_.consume(n);
    handler_.onLinkFrame(n.code, n.body);  // may close() this link
  }
  if (state_ == State::open) input_.settle();
}

}  // namespace skr::sat::detail
