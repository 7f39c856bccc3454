// SPDX-License-Identifier: Apache-2.0
#include "connection.h"

#include "dispatch.h"
#include "hub.h"

#include <skrobot/runtime/log.h>

#include <algorithm>
#include <cstring>
#include <utility>

namespace skr::flow {
namespace {

constexpr size_t kReadChunk = 64 * 1024;
constexpr size_t kKeepBuffer = 1 << 20;        // shrink buffers above this once they drain
constexpr size_t kGiveAwayBytes = 256 * 1024;  // takeBody hands over the buffer from this size
constexpr size_t kWriteSlice = 256 << 10;      // queued output is handed to the socket in slices

}  // namespace

Connection* connectionOf(Hub& hub, uint32_t id) noexcept {
  return hub.connection(id);
}

Connection::Connection(Hub& hub, Transport transport)
    : hub_(hub),
      transport_(transport),
      splitter_(std::min(kPreLoginMaxFrameBytes, hub.opt.max_frame_bytes)) {
  handle_.pipe.data = this;  // both members start with the uv_handle_t fields
}

// The close callback deletes a connection, possibly after the server is gone: close() has
// already detached it from the server, so the destructor must not touch it.
Connection::~Connection() = default;

std::string Connection::describe() const {
  std::string s = "connection " + std::to_string(id);
  if (!user.empty()) s += " (" + user + (client_name.empty() ? "" : "/" + client_name) + ")";
  s += transport_ != Transport::tcp ? " unix" : tls_ ? " tls" : " tcp";
  return s;
}

bool Connection::congested() const {
  return out_.size() > hub_.opt.subscriber_queue_bytes;
}

void Connection::startReading() {
  if (reading_ || state_ == State::closing) return;
  if (int rc = uv_read_start(stream(), &Connection::onAlloc, &Connection::onRead); rc < 0) {
    close(uv_strerror(rc));
    return;
  }
  reading_ = true;
}

void Connection::useTls(TlsSession session) {
  tls_.emplace(std::move(session));
  tls_in_ = std::make_unique_for_overwrite<char[]>(kReadChunk);
}

void Connection::reserveRead(size_t want) {
  if (rcap_ - rend_ >= want) return;
  const size_t have = rend_ - rstart_;
  if (rstart_ > 0) {
    if (have > 0) std::memmove(rbuf_.get(), rbuf_.get() + rstart_, have);
    rstart_ = 0;
    rend_ = have;
  }
  if (rcap_ - rend_ < want) {
    const size_t cap = rend_ + want;
    auto bigger = std::make_unique_for_overwrite<char[]>(cap);  // no zero-fill
    if (have > 0) std::memcpy(bigger.get(), rbuf_.get(), have);
    rbuf_ = std::move(bigger);
    rcap_ = cap;
  }
}

SharedBytes Connection::takeBody(std::string_view part) {
  if (part.size() < kGiveAwayBytes) return SharedBytes(std::string(part));
  std::shared_ptr<const char[]> taken(std::move(rbuf_));
  const size_t have = rend_ - rstart_;
  rcap_ = std::max(kReadChunk, have);
  rbuf_ = std::make_unique_for_overwrite<char[]>(rcap_);
  if (have > 0) std::memcpy(rbuf_.get(), taken.get() + rstart_, have);
  rstart_ = 0;
  rend_ = have;
  return SharedBytes(std::move(taken), part);
}

void Connection::onAlloc(uv_handle_t* h, size_t, uv_buf_t* buf) {
  auto* c = static_cast<Connection*>(h->data);
  if (c->tls_) {  // ciphertext: decrypted into rbuf_ by receiveTls
    *buf = uv_buf_init(c->tls_in_.get(), static_cast<unsigned>(kReadChunk));
    return;
  }
  const size_t have = c->rend_ - c->rstart_;
  // Room for the rest of the frame being received (its length was checked against the limit by
  // the splitter before rneed_ was set), and at least one chunk.
  c->reserveRead(std::max(kReadChunk, c->rneed_ > have ? c->rneed_ - have : 0));
  *buf = uv_buf_init(c->rbuf_.get() + c->rend_, static_cast<unsigned>(c->rcap_ - c->rend_));
}

void Connection::onRead(uv_stream_t* s, ssize_t nread, const uv_buf_t* buf) {
  auto* c = static_cast<Connection*>(s->data);
  if (nread == 0) return;
  if (nread < 0) {
    if (c->tls_ && !c->tls_->established() && !c->first_input_) {
      c->refuse("the client closed the connection during the TLS handshake", {});
      return;
    }
    c->close(nread == UV_EOF ? "peer closed the connection" : uv_strerror(static_cast<int>(nread)));
    return;
  }
  c->hub_.loop.noteActivity();
  if (c->tls_) {
    c->receiveTls(buf->base, static_cast<size_t>(nread));
    return;
  }
  c->rend_ += static_cast<size_t>(nread);
  if (c->first_input_) {
    c->first_input_ = false;
    if (c->transport_ == Transport::tcp &&
        looksLikeTls(std::string_view(c->rbuf_.get() + c->rstart_, c->rend_ - c->rstart_))) {
      c->refuse(
          "a TLS client on the plain TCP port (the hub has no server.tls; the client "
          "should use a tcp: address)",
          {});
      return;
    }
  }
  c->processInput();
}

void Connection::receiveTls(const char* data, size_t n) {
  if (first_input_) {
    first_input_ = false;
    if (!looksLikeTls(std::string_view(data, n))) {
      // A plain FlowProtocol client: it waits for the reply to its LOGIN, so tell it in its own
      // language before closing.
      std::string reply;
      (void)encode(reply, msg::ReplyError{static_cast<uint16_t>(ErrorCode::protocol_error),
                                          "this hub's TCP port speaks TLS: connect with a tls: "
                                          "address (docs/security.md)"});
      refuse("a plain TCP client on the TLS port", std::move(reply));
      return;
    }
  }
  const bool was_established = tls_->established();
  if (auto r = tls_->receive(std::string_view(data, n)); !r) {
    std::string alert;
    tls_->takeOutput(alert);
    refuse(r.error().message, std::move(alert));
    return;
  }
  if (!was_established && tls_->established()) {
    log::debug(kLogSource, "FLOW-TLS", describe() + ": " + tls_->describe());
  }
  // Everything decrypted now goes into rbuf_: the splitter then sees exactly what a plain
  // connection would have read.
  for (;;) {
    reserveRead(kReadChunk);
    auto got = tls_->read(rbuf_.get() + rend_, rcap_ - rend_);
    if (!got) {
      if (got.error().code == Errc::closed) {
        close("peer closed TLS");
      } else {
        refuse(got.error().message, {});
      }
      return;
    }
    if (*got == 0) break;
    rend_ += *got;
  }
  if (tls_->hasOutput()) hub_.markDirty(this);  // handshake records
  processInput();
}

void Connection::refuse(const std::string& why, std::string reply) {
  ++hub_.stats.tls_refused;
  log::warn(kLogSource, "FLOW-TLS", "refusing " + describe() + ": " + why);
  if (!reply.empty()) {
    // Best effort, on a fresh connection whose socket buffer is empty: one try, no queueing.
    uv_buf_t b = uv_buf_init(reply.data(), static_cast<unsigned>(reply.size()));
    (void)uv_try_write(stream(), &b, 1);
  }
  tls_.reset();  // nothing more to encrypt
  close("refused");
}

void Connection::processInput() {
  while (!blocked_ && state_ != State::closing) {
    const auto n =
        splitter_.next(reinterpret_cast<const uint8_t*>(rbuf_.get()) + rstart_, rend_ - rstart_);
    if (n.status == FrameSplitter::Status::need_more) {
      rneed_ = n.wanted;
      break;
    }
    if (n.status == FrameSplitter::Status::too_large) {
      protocolError("frame length " + std::to_string(n.announced) + " exceeds the limit of " +
                    std::to_string(splitter_.maxFrameBytes()) + " bytes" +
                    (state_ == State::login ? " before login" : ""));
      return;
    }
    if (n.status == FrameSplitter::Status::empty_frame) {
      protocolError("frame length 0 (a frame holds at least its code)");
      return;
    }
    if (waitForPipeline(n.code)) break;  // handled once the pipeline's answers have left
    rstart_ += n.consumed;                  // before handling: a handler may block and resume later
    rneed_ = 0;
    ++hub_.stats.frames_in;
    ++traffic.messages_in;
    traffic.bytes_in += n.consumed;
    handleFrame(n.code, n.body);
  }
  if (rstart_ == rend_) {
    rstart_ = rend_ = 0;
    if (rcap_ > kKeepBuffer) {
      rbuf_.reset();
      rcap_ = 0;
    }
  }
}

void Connection::block() {
  blocked_ = true;
  if (reading_) uv_read_stop(stream());
  reading_ = false;
}

void Connection::unblock() {
  if (!blocked_) return;
  blocked_ = false;
  processInput();
  if (!blocked_ && state_ != State::closing) startReading();
}

namespace {

// The answer to a code no minor assigned (docs/flow-protocol.md, rule 5): a newer peer may use it.
std::string unassigned(const std::string& name) {
  return name + " is not assigned in this hub's protocol 1." + std::to_string(kProtocolMinor);
}

}  // namespace

void Connection::handleFrame(uint8_t code, std::string_view body) {
  // What the catalogue says of the code: a hub-to-satellite code (or one of the range kept for
  // them) breaks the protocol; one no minor assigned is answered `unsupported` (rule 5).
  const CodeInfo* info = codeInfo(code);
  if ((info != nullptr && info->direction == Direction::to_client) ||
      (info == nullptr && code >= 0x80 && code <= 0xBF)) {
    char hex[8];
    std::snprintf(hex, sizeof hex, "0x%02x", code);
    protocolError("code " + std::string(hex) + " (" + std::string(codeName(code)) +
                  ") is not sent by satellites");
    return;
  }
  const std::string name(codeName(code));
  switch (state_) {
    case State::login:
      if (static_cast<Code>(code) == Code::login) {
        dispatchFrame(code, body);
      } else {
        replyError(ErrorCode::not_logged_in, name + " before LOGIN");
        closeAfterFlush("command before login");
      }
      return;
    case State::authenticating:
    case State::closing:
      return;  // not reached: reading is paused
    case State::sync:
      if (info == nullptr) {
        replyError(ErrorCode::unsupported, unassigned(name));
      } else if (!info->synchronous()) {
        replyError(ErrorCode::invalid_argument, name + " is asynchronous: send GO_ASYNC first");
      } else if (info->minor > minor_) {
        replyError(ErrorCode::unsupported,
                   name + " is newer than this connection's protocol 1." + std::to_string(minor_));
      } else {
        dispatchFrame(code, body);
      }
      return;
    case State::flow: {
      const auto refuse = [&](const std::string& why) {
        onError(static_cast<Code>(code), 0, 0, ErrorCode::unsupported, why);
      };
      if (info == nullptr) {
        refuse(unassigned(name));
      } else if (info->synchronous()) {
        refuse(name + " is synchronous: use a synchronous connection, the flow never blocks");
      } else if (info->minor > minor_) {
        refuse(name + " is newer than this connection's protocol 1." + std::to_string(minor_));
      } else {
        dispatchFrame(code, body);
      }
      return;
    }
  }
}

void Connection::protocolError(const std::string& why) {
  ++hub_.stats.protocol_errors;
  log::warn(kLogSource, "FLOW-PROTOCOL", "killing spurious client, " + describe() + ": " + why);
  close("protocol error");
}

void Connection::replyError(ErrorCode error, const std::string& message) {
  send(msg::ReplyError{static_cast<uint16_t>(error), message.substr(0, 0xFFFF)});
}

void Connection::replyOk() {
  appendHeader(out_, Code::reply_ok, 0);
  ++traffic.messages_out;
  traffic.bytes_out += kFrameHeaderBytes;
  queued();
}

void Connection::reply(const Result<void>& r) {
  if (r) {
    replyOk();
  } else {
    replyError(toErrorCode(r.error().code), r.error().message);
  }
}

void Connection::replyValue(Result<Variant>&& r) {
  if (r) {
    send(msg::ReplyValue{std::move(*r)});
  } else {
    replyError(toErrorCode(r.error().code), r.error().message);
  }
}

void Connection::refused(Code command, uint32_t tag, uint16_t chan_id, const Result<void>& r) {
  if (!r) onError(command, tag, chan_id, toErrorCode(r.error().code), r.error().message);
}

void Connection::answerDone(const Result<void>& r) {
  reply(r);
  unblock();
}

std::function<void(Result<void>)> Connection::whenDone(
    std::function<void(Connection&, Result<void>)> then) {
  return whenAlive<Result<void>>(std::move(then));
}

std::function<void(Result<Variant>)> Connection::whenRead(
    std::function<void(Connection&, Result<Variant>)> then) {
  return whenAlive<Result<Variant>>(std::move(then));
}

// --- the session's steps -----------------------------------------------------------------------

void Connection::authenticating(ValueEncoding enc) {
  enc_ = enc;
  state_ = State::authenticating;
  block();
}

void Connection::loggedIn(uint16_t minor) {
  minor_ = minor;
  splitter_.setMaxFrameBytes(hub_.opt.max_frame_bytes);
  state_ = State::sync;
}

void Connection::becomeFlow() {
  state_ = State::flow;
}

void Connection::dispatchFrame(uint8_t code, std::string_view body) {
  current_code_ = code;
  dispatch(hub_, *this, code, body);
}

// --- the pipeline ------------------------------------------------------------------------------

bool Connection::waitForPipeline(uint8_t code) {
  if (state_ != State::sync || pipeline_in_flight_ == 0) return false;
  const CodeInfo* info = codeInfo(code);
  if (info != nullptr && info->family == pipeline_family_ && info->direction == Direction::to_hub) {
    return false;  // another request of the pipeline: in order with the others
  }
  pipeline_waiting_ = true;
  block();
  return true;
}

void Connection::pausePipeline() {
  pipeline_waiting_ = true;
  block();
}

void Connection::pipelineAnswered(uint64_t bytes) {
  --pipeline_in_flight_;
  pipeline_bytes_ -= bytes;
  if (pipeline_waiting_) {
    pipeline_waiting_ = false;
    unblock();
  }
}

void Connection::close(const char* why) noexcept {
  if (state_ == State::closing) return;
  if (tls_ && tls_->established() && !writing_) {
    // close_notify, so that the peer can tell our close from a cut connection.
    tls_->shutdown();
    std::string bye;
    tls_->takeOutput(bye);
    uv_buf_t b = uv_buf_init(bye.data(), static_cast<unsigned>(bye.size()));
    if (!bye.empty()) (void)uv_try_write(stream(), &b, 1);
  }
  state_ = State::closing;
  log::debug(kLogSource, "FLOW-CLOSE", describe() + ": " + why);
  hub_.removeEndpoint(*this);
  if (flush_queued) std::erase(hub_.dirty, this);
  flush_queued = false;
  if (reading_) uv_read_stop(stream());
  reading_ = false;
  uv_close(reinterpret_cast<uv_handle_t*>(&handle_),
           [](uv_handle_t* h) { delete static_cast<Connection*>(h->data); });
}

void Connection::closeAfterFlush(const char* why) {
  close_after_flush_ = true;
  log::debug(kLogSource, "FLOW-CLOSE", describe() + ": " + why + " (after sending replies)");
  block();
  hub_.markDirty(this);
}

// --- output ----------------------------------------------------------------------------------

void Connection::sendBlobData(uint64_t version, uint64_t total_size, std::string frame) {
  std::string head;
  (void)encode(head, msg::BlobData{version, total_size, {}});
  ByteWriter(head).patchU32(0, static_cast<uint32_t>(frame.size() - 4));
  std::memcpy(frame.data(), head.data(), head.size());
  ++traffic.messages_out;
  traffic.bytes_out += frame.size();
  if (out_.empty() && whole_.empty()) {
    out_.swap(frame);
  } else if (tls_) {
    out_.append(frame);  // encrypted with the rest at the next flush
  } else {
    // Queued whole rather than copied onto the output on the loop thread: what is in out_ goes
    // first, then this frame, then what comes after it.
    if (!out_.empty()) whole_.push_back(std::exchange(out_, std::string()));
    whole_.push_back(std::move(frame));
  }
  queued();
}

void Connection::widenSendBuffer() {
  if (wide_send_buffer_ || transport_ != Transport::unix_socket) return;
  wide_send_buffer_ = true;
  int size = 1 << 20;  // Linux doubles it (and caps it at net.core.wmem_max)
  (void)uv_send_buffer_size(reinterpret_cast<uv_handle_t*>(stream()), &size);
}


void Connection::queued() {
  if (state_ == State::closing) {
    out_.clear();
    whole_.clear();
    return;
  }
  const size_t hard =
      hub_.opt.subscriber_queue_bytes * 2 + hub_.opt.max_frame_bytes + (64u << 10);
  if (out_.size() > hard) {
    log::warn(kLogSource, "FLOW-SLOW-CLIENT",
              describe() + ": " + std::to_string(out_.size()) +
                  " bytes of events and replies wait unread; closing");
    close("not reading");
    return;
  }
  hub_.markDirty(this);
}

void Connection::onData(const Channel& ch, std::string_view payload) {
  if (state_ != State::flow) return;
  const size_t frame = kFrameHeaderBytes + 2 + payload.size();
  const size_t limit = hub_.opt.subscriber_queue_bytes;
  if (!out_.empty() && out_.size() + frame > limit) {
    dropOldestData(frame);
    if (!out_.empty() && out_.size() + frame > limit) {
      ++dropped_[ch.id];
      ++ch.dropped;
      ++traffic.dropped;
      ++hub_.stats.data_frames_dropped;
      return;
    }
  }
  // One resize and two copies: this runs once per subscriber per message.
  const size_t at = out_.size();
  out_.resize(at + frame);
  char* p = out_.data() + at;
  const uint32_t length = static_cast<uint32_t>(1 + 2 + payload.size());
  std::memcpy(p, &length, 4);
  p[4] = static_cast<char>(Code::ev_data);
  std::memcpy(p + 5, &ch.id, 2);
  if (!payload.empty()) std::memcpy(p + 7, payload.data(), payload.size());
  ++hub_.stats.data_frames_out;
  ++traffic.messages_out;
  traffic.bytes_out += frame;
  if (!flush_queued) hub_.markDirty(this);
}

// A slow subscriber loses its oldest data frames; events and replies are kept. Drops a quarter
// more than needed so that a subscriber that stays slow is not compacted for every frame.
void Connection::dropOldestData(size_t needed) {
  const size_t limit = hub_.opt.subscriber_queue_bytes;
  const size_t target = limit - std::min(limit, needed + limit / 4);
  size_t size = out_.size();
  std::string kept;
  kept.reserve(out_.size());
  size_t pos = 0;
  uint64_t dropped = 0;
  while (pos + kFrameHeaderBytes <= out_.size()) {
    uint32_t len = 0;
    std::memcpy(&len, out_.data() + pos, 4);
    const size_t frame = 4 + static_cast<size_t>(len);
    const auto code = static_cast<Code>(static_cast<uint8_t>(out_[pos + 4]));
    if (code == Code::ev_data && size > target) {
      uint16_t chan = 0;
      std::memcpy(&chan, out_.data() + pos + 5, 2);
      ++dropped_[chan];
      ++dropped;
      if (const Channel* ch = hub_.channels.find(chan)) ++ch->dropped;
      size -= frame;
    } else {
      kept.append(out_, pos, frame);
    }
    pos += frame;
  }
  out_.swap(kept);
  traffic.dropped += dropped;
  hub_.stats.data_frames_dropped += dropped;
  const Nanos now = monotonicNs();
  if (now - last_drop_log_ > kNsPerSec) {
    last_drop_log_ = now;
    log::warn(kLogSource, "FLOW-SLOW-SUBSCRIBER",
              describe() + ": dropped " + std::to_string(dropped) + " oldest data frames (" +
                  std::to_string(traffic.dropped) + " in all), its queue holds " +
                  std::to_string(limit) + " bytes");
  }
}

void Connection::flush() {
  if (writing_ || state_ == State::closing) return;
  if (!dropped_.empty()) {
    for (const auto& [chan, count] : dropped_) {
      (void)encode(out_, msg::EvDropped{chan, count}, enc_);
    }
    dropped_.clear();
  }
  if (tls_) {
    // Ciphertext has no frame boundaries to slice at: urgent frames go ahead of the plaintext not
    // encrypted yet, and the queue holds whole frames up to here (dropOldestData reads it).
    for (std::string* plain : {&urgent_, &out_}) {
      if (plain->empty()) continue;
      auto w = tls_->write(*plain);
      plain->clear();
      if (!w) {
        refuse(w.error().message, {});
        return;
      }
    }
    tls_->takeOutput(out_);
  } else if (!urgent_.empty() && atFrameBoundary()) {
    if (!writeUrgent()) return;
  }
  if (inflight_off_ < inflight_.size()) {
    writeSlice();
    return;
  }
  releaseInflight();
  if (!whole_.empty()) {
    inflight_ = std::move(whole_.front());
    whole_.pop_front();
    writeSlice();
    return;
  }
  if (out_.empty()) {
    if (close_after_flush_) close("replies sent");
    return;
  }
  // Try the socket directly first: when everything fits (the common case) no write request is
  // queued, and libuv does not have to watch the socket for writability.
  uv_buf_t direct = uv_buf_init(out_.data(), static_cast<unsigned>(out_.size()));
  const int sent = uv_try_write(stream(), &direct, 1);
  if (sent == static_cast<int>(out_.size())) {
    if (out_.capacity() > kKeepBuffer) {
      std::string().swap(out_);  // a burst is over: give the memory back
    } else {
      out_.clear();
    }
    if (close_after_flush_) close("replies sent");
    return;
  }
  if (sent < 0 && sent != UV_EAGAIN) {
    close(uv_strerror(sent));
    return;
  }
  inflight_.swap(out_);
  out_.clear();
  inflight_off_ = sent > 0 ? static_cast<size_t>(sent) : 0;
  next_frame_ = 0;
  writeSlice();
}

bool Connection::atFrameBoundary() {
  if (inflight_off_ >= inflight_.size()) return true;
  while (next_frame_ < inflight_off_) {
    uint32_t len = 0;
    std::memcpy(&len, inflight_.data() + next_frame_, 4);
    next_frame_ += 4 + static_cast<size_t>(len);
  }
  return next_frame_ == inflight_off_;
}

bool Connection::writeUrgent() {
  uv_buf_t b = uv_buf_init(urgent_.data(), static_cast<unsigned>(urgent_.size()));
  const int sent = uv_try_write(stream(), &b, 1);
  if (sent == static_cast<int>(urgent_.size())) {
    urgent_.clear();
    return true;
  }
  if (sent < 0 && sent != UV_EAGAIN) {
    close(uv_strerror(sent));
    return false;
  }
  // The socket is full: the rest goes first, on its own.
  urgent_wire_.assign(urgent_, sent > 0 ? static_cast<size_t>(sent) : 0);
  urgent_.clear();
  writing_urgent_ = true;
  writing_ = true;
  uv_buf_t rest = uv_buf_init(urgent_wire_.data(), static_cast<unsigned>(urgent_wire_.size()));
  if (int rc = uv_write(&wreq_, stream(), &rest, 1, &Connection::onWrite); rc < 0) {
    writing_ = false;
    close(uv_strerror(rc));
  }
  return false;
}

void Connection::writeSlice() {
  // Whole frames of at least kWriteSlice bytes, so that urgent frames wait behind one slice at
  // most; a larger frame goes in slices of kWriteSlice too, so that no write holds the loop for
  // long (urgent frames wait for its end: atFrameBoundary). TLS output is written whole.
  size_t end = inflight_.size();
  if (!tls_) {
    size_t last_start = 0;  // where the last frame added below starts
    while (next_frame_ < inflight_.size() &&
           (next_frame_ <= inflight_off_ || next_frame_ - inflight_off_ < kWriteSlice)) {
      last_start = next_frame_;
      uint32_t len = 0;
      std::memcpy(&len, inflight_.data() + next_frame_, 4);
      next_frame_ += 4 + static_cast<size_t>(len);
    }
    end = std::min(next_frame_, inflight_.size());
    if (end - inflight_off_ > kWriteSlice) {
      if (last_start > inflight_off_) {
        end = next_frame_ = last_start;  // the frames before the one that makes it too long
      } else {
        end = inflight_off_ + kWriteSlice;  // inside one frame larger than a slice
      }
    }
  }
  slice_end_ = end;
  uv_buf_t buf =
      uv_buf_init(inflight_.data() + inflight_off_, static_cast<unsigned>(end - inflight_off_));
  writing_ = true;
  if (int rc = uv_write(&wreq_, stream(), &buf, 1, &Connection::onWrite); rc < 0) {
    writing_ = false;
    close(uv_strerror(rc));
  }
}

void Connection::releaseInflight() {
  if (inflight_.capacity() > kKeepBuffer) {
    std::string().swap(inflight_);
  } else {
    inflight_.clear();
  }
  inflight_off_ = next_frame_ = slice_end_ = 0;
}

void Connection::onWrite(uv_write_t* req, int status) {
  auto* c = static_cast<Connection*>(req->handle->data);
  c->writing_ = false;
  if (c->state_ == State::closing) return;
  if (status < 0) {
    c->close(uv_strerror(status));
    return;
  }
  if (c->writing_urgent_) {
    c->writing_urgent_ = false;
    c->urgent_wire_.clear();
  } else {
    c->inflight_off_ = c->slice_end_;
  }
  if (c->inflight_off_ < c->inflight_.size() || !c->urgent_.empty() || !c->whole_.empty() ||
      !c->out_.empty() || !c->dropped_.empty() || c->close_after_flush_) {
    c->flush();
  } else {
    c->releaseInflight();
  }
}

void Connection::onSyncPulse(const Channel& ch, uint64_t seq, uint64_t source_time_ns,
                             uint32_t dropped) {
  if (state_ != State::flow || !sees(ch)) return;
  std::string frame;
  (void)encode(frame, msg::EvSyncPulse{ch.id, seq, source_time_ns, dropped});
  sendUrgent(frame);
}

void Connection::onPhysical(const msg::EvPhysGrant& m) {
  if (state_ == State::flow) send(m);
}
void Connection::onPhysical(const msg::EvPhysPath& m) {
  if (state_ == State::flow) send(m);
}
void Connection::onPhysical(const msg::EvPhysRevoke& m) {
  if (state_ == State::flow) send(m);
}
void Connection::onPhysical(const msg::EvPhysRelay& m) {
  if (state_ == State::flow) send(m);
}
void Connection::onPhysical(const msg::EvPhysSwitch& m) {
  if (state_ == State::flow) send(m);
}
void Connection::onPhysical(const msg::EvPhysResume& m) {
  if (state_ == State::flow) send(m);
}
void Connection::onPhysical(const msg::EvPhysMarker& m) {
  if (state_ == State::flow) send(m);
}

void Connection::sendUrgent(std::string_view frame) {
  if (state_ == State::closing) return;
  urgent_.append(frame);
  ++traffic.messages_out;
  traffic.bytes_out += frame.size();
  hub_.markDirty(this);
}

// --- events ----------------------------------------------------------------------------------

void Connection::onSubscribers(const Channel& ch, bool first) {
  if (state_ != State::flow) return;
  if (first) {
    send(msg::EvStartPublish{ch.id});
  } else {
    send(msg::EvStopPublish{ch.id});
  }
}

void Connection::onRequest(const Channel& ch, uint64_t request, const std::string& command,
                           const std::string& requester, const Variant& value) {
  send(msg::EvServiceRequest{ch.id, request, command, requester, value});
}

void Connection::onResponse(uint16_t chan_id, uint32_t tag, bool sync, ErrorCode error,
                            const Variant& value) {
  if (sync) {
    if (error == ErrorCode::ok) {
      send(msg::ReplyValue{value});
    } else {
      replyError(error, value.isString() ? *value.asString() : std::string(errorCodeName(error)));
    }
    unblock();
    return;
  }
  if (state_ == State::flow) {
    send(msg::EvServiceResponse{chan_id, tag, static_cast<uint16_t>(error), value});
  }
}

bool Connection::sees(const Channel& ch) const noexcept {
  return minor_ >= minorOfKind(ch.kind);
}

void Connection::onChannelAdded(const Channel& ch, uint32_t tag) {
  if (state_ == State::flow && sees(ch)) send(msg::EvChanAdded{tag, hub_.channels.info(ch)});
}

void Connection::onChannelRemoved(const Channel& ch) {
  if (state_ == State::flow && sees(ch)) send(msg::EvChanRemoved{ch.id, ch.hash, ch.name});
}

void Connection::onChannelHeader(const Channel& ch) {
  if (state_ == State::flow && sees(ch)) send(msg::EvChanHeader{hub_.channels.info(ch)});
}

void Connection::onBlobChanged(const Channel& ch, const BlobEvent& ev) {
  if (state_ == State::flow && sees(ch)) {
    send(msg::EvBlobChanged{ch.id, ev.change, ev.path, ev.size, ev.version});
  }
}

void Connection::onError(Code command, uint32_t tag, uint16_t chan_id, ErrorCode error,
                         const std::string& message) {
  send(msg::EvError{static_cast<uint8_t>(command), tag, chan_id, static_cast<uint16_t>(error),
                    message.substr(0, 0xFFFF)});
}

void Connection::onDbChanged(const std::string& name) {
  if (state_ == State::flow) send(msg::EvDbChanged{name});
}

}  // namespace skr::flow
