// SPDX-License-Identifier: Apache-2.0
// A connection's received bytes and the frames split from them, on either side (the hub's
// Connection, the satellite library's Link): a transport reads straight into room() (a large
// frame into memory that already has its size, never zero-filled), peek() tells the next frame
// without taking it, consume() takes it. A message-based transport's whole frames go in through
// append(). Internal to the runtime's users; one connection's, one thread's.
#pragma once

#include <skrobot/runtime/flow/protocol.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <memory>
#include <span>
#include <string_view>

namespace skr::flow {

class FrameInput {
 public:
  static constexpr size_t kReadChunk = size_t{64} * 1024;
  static constexpr size_t kKeepBuffer = size_t{1} << 20;  // shrink above this once drained

  explicit FrameInput(uint32_t max_frame_bytes) : splitter_(max_frame_bytes) {}

  [[nodiscard]] FrameSplitter& splitter() noexcept { return splitter_; }

  // Where the next bytes go: room for the rest of the frame being received (its length was
  // checked against the limit before it was counted) and at least one chunk.
  [[nodiscard]] std::span<char> room() {
    const size_t have = end_ - start_;
    reserve(std::max(kReadChunk, need_ > have ? need_ - have : 0));
    return {buf_.get() + end_, cap_ - end_};
  }
  void commit(size_t n) noexcept { end_ += n; }
  void append(std::string_view bytes) {
    reserve(bytes.size());
    std::memcpy(buf_.get() + end_, bytes.data(), bytes.size());
    end_ += bytes.size();
  }

  // The next frame among the bytes received, not taken yet (its body views this buffer).
  [[nodiscard]] FrameSplitter::Next peek() noexcept {
    auto n = splitter_.next(reinterpret_cast<const uint8_t*>(buf_.get()) + start_, end_ - start_);
    if (n.status == FrameSplitter::Status::need_more) need_ = n.wanted;
    return n;
  }
  // Takes the frame peek() gave; its body stays valid until the buffer next changes.
  void consume(const FrameSplitter::Next& frame) noexcept {
    start_ += frame.consumed;
    need_ = 0;
  }
  // After a round of frames: an emptied buffer starts over at its front, and a large one is
  // given back.
  void settle() noexcept {
    if (start_ != end_) return;
    start_ = end_ = 0;
    if (cap_ > kKeepBuffer) {
      buf_.reset();
      cap_ = 0;
    }
  }

  // Bytes of whole frames handed from one thread to another (the hub's I/O threads,
  // core/src/flow/io_relay.h): a buffer and the range [begin, end) of it that holds them.
  struct Block {
    std::unique_ptr<char[]> buf;
    size_t cap = 0, begin = 0, end = 0;
    [[nodiscard]] size_t size() const noexcept { return end - begin; }
  };
  // The whole frames at the front, taken as a block: the buffer itself when they are large (no
  // copy; what follows them moves to a new buffer), a copy of them otherwise. Empty when no
  // frame is whole yet; a frame above the limit, or empty, is left for peek() to report.
  [[nodiscard]] Block takeFrames() {
    size_t pos = start_;
    for (;;) {
      const auto n = splitter_.next(reinterpret_cast<const uint8_t*>(buf_.get()) + pos, end_ - pos);
      if (n.status != FrameSplitter::Status::frame) {
        if (n.status == FrameSplitter::Status::need_more) need_ = n.wanted + (pos - start_);
        break;
      }
      pos += n.consumed;
    }
    return take(pos);
  }
  // Every byte received and not taken (whole frames or not), as a block.
  [[nodiscard]] Block takeAll() { return take(end_); }
  // A block from another thread's takeFrames() or takeAll(): kept as the buffer when nothing is
  // waiting here (no copy), appended otherwise.
  void adopt(Block block) {
    if (block.size() == 0) return;
    if (start_ != end_) {
      append({block.buf.get() + block.begin, block.size()});
      return;
    }
    buf_ = std::move(block.buf);
    cap_ = block.cap;
    start_ = block.begin;
    end_ = block.end;
    need_ = 0;
  }

  // Gives the whole buffer away (bodies that view it live on in it) and goes on with a new one
  // holding the bytes not taken yet.
  [[nodiscard]] std::shared_ptr<const char[]> giveAway() {
    std::shared_ptr<const char[]> taken(std::move(buf_));
    const size_t have = end_ - start_;
    cap_ = std::max(kReadChunk, have);
    buf_ = std::make_unique_for_overwrite<char[]>(cap_);
    if (have > 0) std::memcpy(buf_.get(), taken.get() + start_, have);
    start_ = 0;
    end_ = have;
    return taken;
  }

 private:
  static constexpr size_t kMoveBlock = size_t{256} * 1024;  // take() moves the buffer from here

  // The bytes [start_, until) as a block; the rest stays.
  Block take(size_t until) {
    Block b;
    const size_t n = until - start_;
    if (n == 0) return b;
    if (n < kMoveBlock) {
      b.buf = std::make_unique_for_overwrite<char[]>(n);
      std::memcpy(b.buf.get(), buf_.get() + start_, n);
      b.cap = b.end = n;
      start_ = until;
      need_ = need_ > n ? need_ - n : 0;
      return b;
    }
    const size_t rest = end_ - until;
    b.buf = std::move(buf_);
    b.cap = cap_;
    b.begin = start_;
    b.end = until;
    cap_ = std::max(kReadChunk, rest);
    buf_ = std::make_unique_for_overwrite<char[]>(cap_);
    if (rest > 0) std::memcpy(buf_.get(), b.buf.get() + until, rest);
    start_ = 0;
    end_ = rest;
    need_ = need_ > n ? need_ - n : 0;
    return b;
  }

  // Room for at least `want` more bytes at the end.
  void reserve(size_t want) {
    if (cap_ - end_ >= want) return;
    const size_t have = end_ - start_;
    if (start_ > 0) {
      if (have > 0) std::memmove(buf_.get(), buf_.get() + start_, have);
      start_ = 0;
      end_ = have;
    }
    if (cap_ - end_ < want) {
      const size_t cap = end_ + want;
      auto bigger = std::make_unique_for_overwrite<char[]>(cap);
      if (have > 0) std::memcpy(bigger.get(), buf_.get(), have);
      buf_ = std::move(bigger);
      cap_ = cap;
    }
  }

  FrameSplitter splitter_;
  std::unique_ptr<char[]> buf_;  // bytes [start_, end_) received and not taken
  size_t cap_ = 0, start_ = 0, end_ = 0, need_ = 0;
};

}  // namespace skr::flow
