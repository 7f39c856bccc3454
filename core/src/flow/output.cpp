// SPDX-License-Identifier: Apache-2.0
#include "output.h"

#include "frame_input.h"

#include <algorithm>
#include <cstring>
#include <utility>

namespace skr::flow {
namespace {

constexpr size_t kWriteSlice = 256 << 10;  // queued output is handed to the transport in slices

// A string done with: a large one gives its memory back (a burst is over).
void release(std::string& s) {
  if (s.capacity() > FrameInput::kKeepBuffer) {
    std::string().swap(s);
  } else {
    s.clear();
  }
}

}  // namespace

void Output::appendWhole(std::string frame) {
  if (out_.empty() && whole_.empty()) {
    out_.swap(frame);
    return;
  }
  // What is in out_ goes first, then this frame, then what comes after it.
  if (!out_.empty()) whole_.push_back(std::exchange(out_, std::string()));
  whole_.push_back(std::move(frame));
}

void Output::clear() noexcept {
  out_.clear();
  whole_.clear();
  urgent_.clear();
}

Result<bool> Output::flush(transport::Transport& transport) {
  if (writing_) return false;
  if (!urgent_.empty() && atFrameBoundary()) {
    auto done = writeUrgent(transport);
    if (!done || !*done) return done;
  }
  if (inflight_off_ < inflight_.size()) {
    if (auto r = writeSlice(transport); !r) return r.error();
    return false;
  }
  releaseInflight();
  if (!whole_.empty()) {
    inflight_ = std::move(whole_.front());
    whole_.pop_front();
    if (auto r = writeSlice(transport); !r) return r.error();
    return false;
  }
  if (out_.empty()) return true;
  // The transport directly first: when everything fits (the common case) no write is kept under
  // way, and the loop does not have to watch the socket for writability.
  const std::string_view direct = out_;
  const auto sent = transport.tryWrite({&direct, 1});
  if (!sent) return sent.error();
  if (*sent == out_.size()) {
    release(out_);
    return true;
  }
  inflight_.swap(out_);
  out_.clear();
  inflight_off_ = *sent;
  next_frame_ = 0;
  if (auto r = writeSlice(transport); !r) return r.error();
  return false;
}

Result<void> Output::written(Result<void> result) {
  writing_ = false;
  if (!result) return result;
  if (writing_urgent_) {
    writing_urgent_ = false;
    urgent_wire_.clear();
  } else {
    inflight_off_ = slice_end_;
  }
  if (!pending()) releaseInflight();
  return {};
}

bool Output::atFrameBoundary() {
  if (inflight_off_ >= inflight_.size()) return true;
  while (next_frame_ < inflight_off_) {
    uint32_t len = 0;
    std::memcpy(&len, inflight_.data() + next_frame_, 4);
    next_frame_ += 4 + static_cast<size_t>(len);
  }
  return next_frame_ == inflight_off_;
}

Result<bool> Output::writeUrgent(transport::Transport& transport) {
  const std::string_view urgent = urgent_;
  const auto sent = transport.tryWrite({&urgent, 1});
  if (!sent) return sent.error();
  if (*sent == urgent_.size()) {
    urgent_.clear();
    return true;
  }
  // The transport is full: the rest goes first, on its own.
  urgent_wire_.assign(urgent_, *sent);
  urgent_.clear();
  writing_urgent_ = true;
  writing_ = true;
  const std::string_view rest = urgent_wire_;
  if (auto r = transport.write({&rest, 1}); !r) {
    writing_ = false;
    return r.error();
  }
  return false;
}

Result<void> Output::writeSlice(transport::Transport& transport) {
  // Whole frames of at least kWriteSlice bytes, so that urgent frames wait behind one slice at
  // most; a larger frame goes in slices of kWriteSlice too, so that no write holds the loop for
  // long (urgent frames wait for its end: atFrameBoundary). A message-based transport takes
  // whole frames only: a frame larger than a slice goes whole.
  size_t last_start = 0;  // where the last frame added below starts
  while (next_frame_ < inflight_.size() &&
         (next_frame_ <= inflight_off_ || next_frame_ - inflight_off_ < kWriteSlice)) {
    last_start = next_frame_;
    uint32_t len = 0;
    std::memcpy(&len, inflight_.data() + next_frame_, 4);
    next_frame_ += 4 + static_cast<size_t>(len);
  }
  size_t end = std::min(next_frame_, inflight_.size());
  if (end - inflight_off_ > kWriteSlice) {
    if (last_start > inflight_off_) {
      end = next_frame_ = last_start;  // the frames before the one that makes it too long
    } else if (transport.framing() == transport::Transport::Framing::stream) {
      end = inflight_off_ + kWriteSlice;  // inside one frame larger than a slice
    }
  }
  slice_end_ = end;
  const std::string_view slice(inflight_.data() + inflight_off_, end - inflight_off_);
  writing_ = true;
  if (auto r = transport.write({&slice, 1}); !r) {
    writing_ = false;
    return r;
  }
  return {};
}

void Output::releaseInflight() {
  release(inflight_);
  inflight_off_ = next_frame_ = slice_end_ = 0;
}

}  // namespace skr::flow
