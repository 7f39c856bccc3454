// SPDX-License-Identifier: Apache-2.0
// A message-framed carrier's session (message_session.h).
#include "message_session.h"

#include <cstring>

namespace skr::flow::transport {

MessageSession::MessageSession(Loop& loop, TransportKind kind, PeerIdentity peer,
                               uint32_t max_frame, size_t pending_bytes, std::string ended_text)
    : kind_(kind),
      peer_(std::move(peer)),
      max_frame_(max_frame),
      pending_limit_(pending_bytes),
      ended_text_(std::move(ended_text)),
      later_(loop, [this] { deliver(); }) {}

Result<void> MessageSession::start(Receiver& receiver) {
  receiver_ = &receiver;
  if (!pending_.empty() || end_) later_.startIn(0);
  return {};
}

Result<void> MessageSession::resume() {
  paused_ = false;
  if (!pending_.empty() || end_) later_.startIn(0);
  return {};
}

void MessageSession::leave() noexcept {
  if (!attached_) return;
  attached_ = false;
  leaveCarrier();
}

bool MessageSession::received(std::string_view frame) {
  if (closing_) return true;
  if (paused_ || receiver_ == nullptr || !pending_.empty()) {
    if (pending_bytes_ + frame.size() > pending_limit_) return false;
    pending_bytes_ += frame.size();
    pending_.emplace_back(frame);
    return true;
  }
  receiver_->message(frame);
  return true;
}

void MessageSession::carrierEnded(TransportEnd end) {
  attached_ = false;
  pending_.clear();  // what the ended session had not read yet is moot
  pending_bytes_ = 0;
  if (closing_) return;
  end_ = std::move(end);
  later_.startIn(0);
}

size_t MessageSession::toCarrier(std::string_view bytes) {
  size_t pos = 0;
  while (attached_ && pos + 4 <= bytes.size()) {
    uint32_t len = 0;
    std::memcpy(&len, bytes.data() + pos, 4);
    const size_t whole = 4 + static_cast<size_t>(len);
    if (whole > bytes.size() - pos) break;  // not a whole frame: never given by the connection
    if (!sendFrame(bytes.substr(pos, whole))) break;
    pos += whole;
  }
  return pos;
}

Result<size_t> MessageSession::tryWrite(std::span<const std::string_view> buffers) {
  if (!attached_ || closing_) return makeError(Errc::io_error, ended_text_);
  if (write_under_way_) return size_t{0};
  if (buffers.size() == 1) return toCarrier(buffers[0]);
  std::string all;
  for (std::string_view b : buffers) all.append(b);
  return toCarrier(all);
}

Result<void> MessageSession::write(std::span<const std::string_view> buffers) {
  if (!attached_ || closing_) return makeError(Errc::io_error, ended_text_);
  writing_.clear();
  for (std::string_view b : buffers) writing_.append(b);
  written_off_ = 0;
  write_under_way_ = true;
  carrierRoom();
  return {};
}

void MessageSession::carrierRoom() {
  if (!write_under_way_) return;
  written_off_ += toCarrier(std::string_view(writing_).substr(written_off_));
  if (written_off_ < writing_.size() && attached_) return;
  write_under_way_ = false;
  writing_.clear();
  written_due_ = true;
  later_.startIn(0);
}

void MessageSession::close(std::string_view) noexcept {
  if (closing_) return;
  closing_ = true;
  leave();
  pending_.clear();
  later_.startIn(0);
}

void MessageSession::deliver() {
  if (receiver_ == nullptr) return;
  if (closing_) {
    receiver_->closed();  // may destroy this: last
    return;
  }
  if (written_due_) {
    written_due_ = false;
    receiver_->written({});
    if (closing_) return;
  }
  while (!paused_ && !pending_.empty() && !closing_) {
    const std::string f = std::move(pending_.front());
    pending_.pop_front();
    pending_bytes_ -= f.size();
    receiver_->message(f);
  }
  if (end_ && !closing_ && pending_.empty()) {
    const TransportEnd end = *end_;
    end_.reset();
    receiver_->ended(end);
  }
}

}  // namespace skr::flow::transport
