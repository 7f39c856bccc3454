// SPDX-License-Identifier: Apache-2.0
// A connection's output on its transport: the frames queued for the peer and how they are
// written. Frames accumulate in queue(); flush() hands them to the transport, directly when the
// transport takes them all (the common case, no write kept under way), else as a write of whole
// frames a slice at a time, so that an urgent frame (a sync pulse) waits behind one slice at most
// and no write holds the loop for long. Large blob data frames go whole (appendWhole) rather than
// being copied onto the queue. What to queue and when to give up on a slow peer is the
// connection's; this is the mechanics. Main loop thread only.
#pragma once

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/result.h>

#include <cstddef>
#include <deque>
#include <string>
#include <string_view>

namespace skr::flow {

class Output {
 public:
  // Frames are appended here (encode(), or in place).
  [[nodiscard]] std::string& queue() noexcept { return out_; }
  [[nodiscard]] const std::string& queue() const noexcept { return out_; }
  // A frame queued whole after what is queued now, without copying it onto the queue.
  void appendWhole(std::string frame);
  // A frame that goes after the slice being written, ahead of everything else.
  void appendUrgent(std::string_view frame) { urgent_.append(frame); }
  // Bytes queued or being written.
  [[nodiscard]] size_t bytes() const noexcept { return out_.size() + inflight_.size(); }
  [[nodiscard]] bool writing() const noexcept { return writing_; }
  // Whether anything is left to write (a write under way not counted).
  [[nodiscard]] bool pending() const noexcept {
    return inflight_off_ < inflight_.size() || !urgent_.empty() || !whole_.empty() || !out_.empty();
  }
  void clear() noexcept;

  // Writes what can be written now. True when everything left; false while a write is under
  // way (written() follows); Errc::io_error when the transport broke.
  [[nodiscard]] Result<bool> flush(transport::Transport& transport);
  // The transport's written() for the write flush() started; flush() again if pending().
  [[nodiscard]] Result<void> written(Result<void> result);

 private:
  // Whether the next byte to write starts a frame (urgent frames go in only there); the urgent
  // frames, written at once or on their own (false: the write is under way or failed); the
  // next slice of inflight_; inflight_ done with.
  bool atFrameBoundary();
  Result<bool> writeUrgent(transport::Transport& transport);
  Result<void> writeSlice(transport::Transport& transport);
  void releaseInflight();

  // inflight_ is being written, a slice at a time ([inflight_off_, slice_end_) now;
  // next_frame_: a frame start at or past inflight_off_). Urgent frames wait in urgent_
  // (urgent_wire_ while the transport takes their rest). whole_ goes before out_.
  std::string out_, inflight_, urgent_, urgent_wire_;
  std::deque<std::string> whole_;
  size_t inflight_off_ = 0, slice_end_ = 0, next_frame_ = 0;
  bool writing_urgent_ = false;
  bool writing_ = false;
};

}  // namespace skr::flow
