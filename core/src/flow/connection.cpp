// SPDX-License-Identifier: Apache-2.0
#include "connection.h"

#include "dispatch.h"
#include "hub.h"
#include "io_relay.h"

#include <skrobot/runtime/log.h>

#include <sys/socket.h>

#include <algorithm>
#include <cstring>
#include <utility>

namespace skr::flow {
namespace {

constexpr size_t kGiveAwayBytes = 256 * 1024;  // takeBody hands over the buffer from this size

}  // namespace

Connection* connectionOf(Hub& hub, uint32_t id) noexcept {
  return hub.connection(id);
}

namespace {

// What the accounts' rules see of a transport (Connection::transport()).
Transport loginTransport(const transport::Transport& t) {
  switch (t.kind()) {
    case transport::TransportKind::unix_socket:
      return Transport::unix_socket;
    case transport::TransportKind::websocket: {
      return isLoopbackAddress(t.peer().address) ? Transport::websocket_loopback
                                                 : Transport::websocket;
    }
    default:
      return Transport::tcp;
  }
}

}  // namespace

Connection::Connection(Hub& hub, std::unique_ptr<transport::Transport> transport)
    : hub_(hub),
      transport_(std::move(transport)),
      input_(
          std::min({kPreLoginMaxFrameBytes, hub.opt.max_frame_bytes, transport_->maxFrameBytes()})),
      base_queue_(hub.opt.subscriber_queue_bytes),
      queue_limit_(hub.opt.subscriber_queue_bytes) {
  if (transport_->kind() == transport::TransportKind::udp) max_frame_ = transport_->maxFrameBytes();
  login_transport_ = loginTransport(*transport_);
}

// The transport's closed() deletes a connection, possibly after the server is gone: close() has
// already detached it from the server, so the destructor must not touch it.
Connection::~Connection() = default;

std::string Connection::describe() const {
  std::string s = "connection " + std::to_string(id);
  if (!user.empty()) s += " (" + user + (client_name.empty() ? "" : "/" + client_name) + ")";
  s += " ";
  s += transport::transportKindName(transport_->kind());
  return s;
}

bool Connection::congested() const {
  return output_.queue().size() > queue_limit_;
}

void Connection::startReading() {
  if (reading_ || state_ == State::closing) return;
  if (auto r = reading_started_ ? transport_->resume() : transport_->start(*this); !r) {
    close(r.error().message.c_str());
    return;
  }
  reading_started_ = true;
  reading_ = true;
}

SharedBytes Connection::takeBody(std::string_view part) {
  if (part.size() < kGiveAwayBytes) return SharedBytes(std::string(part));
  return SharedBytes(input_.giveAway(), part);
}

std::span<char> Connection::readBuffer() {
  return input_.room();
}

void Connection::received(size_t n) {
  hub_.loop.noteActivity();
  input_.commit(n);
  processInput();
}

void Connection::message(std::string_view bytes) {
  hub_.loop.noteActivity();
  // One whole frame per message: its length prefix must say so.
  uint32_t length = 0;
  if (bytes.size() >= 4) std::memcpy(&length, bytes.data(), 4);
  if (bytes.size() < kFrameHeaderBytes || length + size_t{4} != bytes.size()) {
    protocolError("a message of " + std::to_string(bytes.size()) + " bytes is not one frame");
    return;
  }
  input_.append(bytes);
  processInput();
}

void Connection::ended(const transport::TransportEnd& end) {
  if (end.why == transport::TransportEnd::Why::refused) {
    // The other language (plain on TLS, TLS on plain) or a failed handshake: the transport told
    // the peer what it could.
    ++hub_.stats.tls_refused;
    log::warn(kLogSource, "FLOW-TLS", "refusing " + describe() + ": " + end.message);
    close("refused");
    return;
  }
  close(end.message.c_str());
}

void Connection::closed() noexcept {
  delete this;
}

namespace {

// What one connection's frames may take of a loop turn (docs/internals.md, "Fair turns"): a
// flood of frames in one read yields to the other connections after this much work, or these
// many frames or bytes. Work, because frames differ (a channel made is told to everyone, a
// PUBLISH takes a microsecond); generous, because each yield costs the relay a loop iteration.
constexpr Nanos kTimePerTurn = 1'000'000;
constexpr int kFramesPerTurn = 4096;
constexpr size_t kBytesPerTurn = 4u << 20;

}  // namespace

void Connection::processInput() {
  int frames = 0;
  size_t bytes = 0;
  const Nanos start = monotonicNs();
  while (!blocked_ && !yielding_ && !moving_ && state_ != State::closing) {
    // The clock is read every eighth frame.
    if (frames >= kFramesPerTurn || bytes >= kBytesPerTurn ||
        (frames % 8 == 7 && monotonicNs() - start >= kTimePerTurn)) {
      if (input_.peek().status != FrameSplitter::Status::need_more) yieldTurn();
      break;
    }
    const auto n = input_.peek();
    if (n.status == FrameSplitter::Status::need_more) break;
    if (n.status == FrameSplitter::Status::too_large) {
      protocolError("frame length " + std::to_string(n.announced) + " exceeds the limit of " +
                    std::to_string(input_.splitter().maxFrameBytes()) + " bytes" +
                    (state_ == State::login ? " before login" : ""));
      return;
    }
    if (n.status == FrameSplitter::Status::empty_frame) {
      protocolError("frame length 0 (a frame holds at least its code)");
      return;
    }
    if (movesToIoThread(n.code)) {
      startMove();  // the frame is handled once there
      break;
    }
    if (waitForPipeline(n.code)) break;  // handled once the pipeline's answers have left
    input_.consume(n);                   // before handling: a handler may block and resume later
    ++frames;
    bytes += n.consumed;
    ++hub_.stats.frames_in;
    ++traffic.messages_in;
    traffic.bytes_in += n.consumed;
    handleFrame(n.code, n.body);
  }
  input_.settle();
}

void Connection::relayedInput(FrameInput::Block block) {
  hub_.loop.noteActivity();
  input_.adopt(std::move(block));
  processInput();
}

bool Connection::movesToIoThread(uint8_t code) const {
  if (stays_ || state_ != State::sync || hub_.blobs.ioThread(id) == nullptr) return false;
  const CodeInfo* info = codeInfo(code);
  if (info == nullptr || info->family != Family::blobs) return false;
  const auto kind = transport_->kind();
  return kind == transport::TransportKind::unix_socket || kind == transport::TransportKind::tcp ||
         kind == transport::TransportKind::tls;
}

void Connection::startMove() {
  moving_ = true;
  if (reading_) transport_->pause();
  reading_ = false;
  hub_.loop.post([this, alive = std::weak_ptr<int>(alive_)] {
    if (alive.lock()) finishMove();
  });
}

void Connection::finishMove() {
  if (state_ == State::closing) return;
  if (output_.writing()) {
    move_after_write_ = true;  // written() comes back here
    return;
  }
  stays_ = true;
  auto detached = transport_->detach();
  if (detached) {
    transport_ = std::make_unique<RelayTransport>(
        hub_.loop, hub_.blobs.ioThread(id), std::move(*detached), input_.takeAll(),
        input_.splitter().maxFrameBytes(),
        [this](FrameInput::Block block) { relayedInput(std::move(block)); });
    reading_started_ = false;
    ++hub_.stats.connections_moved;
  } else {
    log::debug(kLogSource, "FLOW-IO-THREAD",
               describe() + " stays on the main loop: " + detached.error().message);
  }
  moving_ = false;
  processInput();
  if (!blocked_ && !yielding_ && !moving_ && state_ != State::closing) startReading();
}

void Connection::block() {
  blocked_ = true;
  if (reading_) transport_->pause();
  reading_ = false;
}

void Connection::unblock() {
  if (!blocked_) return;
  blocked_ = false;
  processInput();
  if (!blocked_ && !yielding_ && !moving_ && state_ != State::closing) startReading();
}

void Connection::yieldTurn() {
  yielding_ = true;
  ++hub_.stats.turns_yielded;
  if (reading_) transport_->pause();
  reading_ = false;
  hub_.loop.post([this, alive = std::weak_ptr<int>(alive_)] {
    if (alive.lock()) resumeTurn();
  });
}

void Connection::resumeTurn() {
  if (!yielding_) return;
  yielding_ = false;
  processInput();
  if (!blocked_ && !yielding_ && !moving_ && state_ != State::closing) startReading();
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
      if (static_cast<Code>(code) == Code::login || static_cast<Code>(code) == Code::login_token) {
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
      } else if (info->family == Family::blobs &&
                 transport_->kind() == transport::TransportKind::udp) {
        // A datagram carries one frame below the path's MTU: blob transfers are not for UDP.
        replyError(ErrorCode::unsupported, name + ": no blob transfers on a UDP session");
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
      } else if (info->family == Family::physical &&
                 transport_->kind() == transport::TransportKind::websocket) {
        // Shared memory and descriptors do not cross a WebSocket; the relay serves its data.
        refuse(name + ": no physical paths over WebSocket");
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
  const std::string reason = "protocol error: " + why;  // a WebSocket peer reads it
  close(reason.c_str());
}

void Connection::replyError(ErrorCode error, const std::string& message) {
  send(msg::ReplyError{static_cast<uint16_t>(error), message.substr(0, 0xFFFF)});
}

void Connection::replyOk() {
  appendHeader(output_.queue(), Code::reply_ok, 0);
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
  input_.splitter().setMaxFrameBytes(
      std::min(hub_.opt.max_frame_bytes, transport_->maxFrameBytes()));
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

void Connection::pipelineAnswer(uint64_t place, uint64_t bytes,
                                std::function<void(Connection&)> answer) {
  if (place != pipeline_sent_) {
    pipeline_held_.emplace(place, Held{bytes, std::move(answer)});
    return;
  }
  answer(*this);
  ++pipeline_sent_;
  pipelineAnswered(bytes);
  while (!pipeline_held_.empty() && pipeline_held_.begin()->first == pipeline_sent_) {
    Held next = std::move(pipeline_held_.begin()->second);
    pipeline_held_.erase(pipeline_held_.begin());
    next.answer(*this);
    ++pipeline_sent_;
    pipelineAnswered(next.bytes);
  }
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
  state_ = State::closing;
  log::debug(kLogSource, "FLOW-CLOSE", describe() + ": " + why);
  hub_.removeEndpoint(*this);
  if (flush_queued) std::erase(hub_.dirty, this);
  flush_queued = false;
  reading_ = false;
  transport_->close(why);  // closed() follows from the loop
}

void Connection::closeAfterFlush(const char* why) {
  close_after_flush_ = true;
  log::debug(kLogSource, "FLOW-CLOSE", describe() + ": " + why + " (after sending replies)");
  block();
  hub_.markDirty(this);
}

// --- output ----------------------------------------------------------------------------------

void Connection::sendBlobData(uint64_t version, uint64_t total_size, std::string frame) {
  if (max_frame_ != 0 && frame.size() > max_frame_) {
    tooLarge(true);
    return;
  }
  std::string head;
  (void)encode(head, msg::BlobData{version, total_size, {}});
  ByteWriter(head).patchU32(0, static_cast<uint32_t>(frame.size() - 4));
  std::memcpy(frame.data(), head.data(), head.size());
  ++traffic.messages_out;
  traffic.bytes_out += frame.size();
  output_.appendWhole(std::move(frame));  // not copied onto the queue on the loop thread
  queued();
}

void Connection::widenSendBuffer() {
  if (wide_send_buffer_ || transport_->kind() != transport::TransportKind::unix_socket) return;
  wide_send_buffer_ = true;
  const int size = 1 << 20;  // Linux doubles it (and caps it at net.core.wmem_max)
  if (const int fd = transport_->descriptor(); fd >= 0) {
    (void)::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &size, sizeof size);
  }
}

void Connection::queued() {
  if (state_ == State::closing) {
    output_.clear();
    return;
  }
  const size_t hard = queue_limit_ * 2 + hub_.opt.max_frame_bytes + (64u << 10);
  if (output_.queue().size() > hard) {
    log::warn(kLogSource, "FLOW-SLOW-CLIENT",
              describe() + ": " + std::to_string(output_.queue().size()) +
                  " bytes of events and replies wait unread; closing");
    close("not reading");
    return;
  }
  hub_.markDirty(this);
}

void Connection::onData(const Channel& ch, std::string_view payload) {
  if (state_ != State::flow) return;
  if (rates_ && !rates_->admit(ch.id, payload, monotonicNs())) return;  // waits, or skipped
  queueData(ch, payload);
}

void Connection::queueData(const Channel& ch, std::string_view payload) {
  std::string& out = output_.queue();
  const size_t frame = kFrameHeaderBytes + 2 + payload.size();
  if (max_frame_ != 0 && frame > max_frame_) {
    ++frames_too_large;
    ++ch.dropped;
    ++traffic.dropped;
    ++hub_.stats.data_frames_dropped;
    return;
  }
  const size_t limit = queue_limit_;
  if (!out.empty() && out.size() + frame > limit) {
    dropOldestData(frame);
    if (!out.empty() && out.size() + frame > limit) {
      ++dropped_[ch.id];
      ++ch.dropped;
      ++traffic.dropped;
      ++hub_.stats.data_frames_dropped;
      return;
    }
  }
  // One resize and two copies: this runs once per subscriber per message.
  const size_t at = out.size();
  out.resize(at + frame);
  char* p = out.data() + at;
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
  std::string& out = output_.queue();
  const size_t limit = queue_limit_;
  const size_t target = limit - std::min(limit, needed + limit / 4);
  size_t size = out.size();
  std::string kept;
  kept.reserve(out.size());
  size_t pos = 0;
  uint64_t dropped = 0;
  while (pos + kFrameHeaderBytes <= out.size()) {
    uint32_t len = 0;
    std::memcpy(&len, out.data() + pos, 4);
    const size_t frame = 4 + static_cast<size_t>(len);
    const auto code = static_cast<Code>(static_cast<uint8_t>(out[pos + 4]));
    if (code == Code::ev_data && size > target) {
      uint16_t chan = 0;
      std::memcpy(&chan, out.data() + pos + 5, 2);
      ++dropped_[chan];
      ++dropped;
      if (const Channel* ch = hub_.channels.find(chan)) ++ch->dropped;
      size -= frame;
    } else {
      kept.append(out, pos, frame);
    }
    pos += frame;
  }
  out.swap(kept);
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

size_t Connection::askQueue(uint16_t chan_id, size_t bytes) {
  const size_t cap = queue_fixed_ ? base_queue_ : hub_.opt.subscriber_queue_max_bytes;
  const size_t granted = std::min(bytes, cap);
  if (granted == 0) {
    queue_asked_.erase(chan_id);
  } else {
    queue_asked_[chan_id] = granted;
  }
  resizeQueue();
  return granted;
}

void Connection::releaseQueue(uint16_t chan_id) {
  if (queue_asked_.erase(chan_id) != 0) resizeQueue();
  if (rates_) rates_->remove(chan_id);
}

void Connection::capRate(uint16_t chan_id, uint16_t max_hz) {
  if (!rates_) {
    if (max_hz == 0) return;
    rates_ = std::make_unique<RateCaps>(hub_.loop, [this](uint16_t chan, std::string_view payload) {
      const Channel* ch = hub_.channels.find(chan);
      if (ch != nullptr && state_ == State::flow) queueData(*ch, payload);
    });
  }
  rates_->set(chan_id, max_hz);
}

Endpoint::RateCap Connection::rateCap(uint16_t chan) const {
  if (!rates_) return {};
  const RateCaps::Info i = rates_->info(chan);
  return {i.max_hz, i.skipped};
}

void Connection::resizeQueue() noexcept {
  queue_limit_ = base_queue_;
  for (const auto& [chan, bytes] : queue_asked_) queue_limit_ = std::max(queue_limit_, bytes);
}

void Connection::flush() {
  if (output_.writing() || state_ == State::closing) return;
  for (const auto& [chan, count] : dropped_) {
    (void)encode(output_.queue(), msg::EvDropped{chan, count}, enc_);
  }
  dropped_.clear();
  const auto done = output_.flush(*transport_);
  if (!done) {
    close(done.error().message.c_str());
  } else if (*done && close_after_flush_) {
    close("replies sent");
  }
}

void Connection::written(Result<void> result) {
  if (state_ == State::closing) return;
  if (auto r = output_.written(std::move(result)); !r) {
    close(r.error().message.c_str());
    return;
  }
  if (output_.pending() || !dropped_.empty() || close_after_flush_) flush();
  if (move_after_write_ && !output_.writing()) {
    move_after_write_ = false;
    finishMove();
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
  if (max_frame_ != 0 && frame.size() > max_frame_) {
    ++frames_too_large;
    return;
  }
  output_.appendUrgent(frame);
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

void Connection::limitSession(uint32_t max_frame, bool channel_events, NameFilter watch) {
  max_frame_ = max_frame;
  // A datagram carries one frame: nothing larger is sent on a UDP session, whatever the board
  // said (a reply above it becomes limit_exceeded rather than a datagram never sent).
  if (transport_->kind() == transport::TransportKind::udp) {
    const uint32_t datagram = transport_->maxFrameBytes();
    max_frame_ = max_frame_ == 0 ? datagram : std::min(max_frame_, datagram);
  }
  channel_events_ = channel_events;
  watch_ = std::move(watch);
}

bool Connection::hearsOf(const Channel& ch) const {
  if (channel_events_ || ch.owner == this) return true;
  const auto in = [this](const std::vector<Endpoint*>& list) {
    return std::find(list.begin(), list.end(), this) != list.end();
  };
  return in(ch.subscribers) || in(ch.physical) || watch_.selects(ch.name);
}

void Connection::tooLarge(bool reply) {
  ++frames_too_large;
  if (reply) replyError(ErrorCode::limit_exceeded, "reply above the session's frame limit");
}

bool Connection::sees(const Channel& ch) const noexcept {
  return minor_ >= minorOfKind(ch.kind);
}

void Connection::onChannelAdded(const Channel& ch, uint32_t tag) {
  if (state_ == State::flow && sees(ch) && hearsOf(ch))
    send(msg::EvChanAdded{tag, hub_.channels.info(ch)});
}

void Connection::onChannelRemoved(const Channel& ch) {
  releaseQueue(ch.id);
  if (state_ == State::flow && sees(ch) && hearsOf(ch))
    send(msg::EvChanRemoved{ch.id, ch.hash, ch.name});
}

void Connection::onChannelHeader(const Channel& ch) {
  if (state_ == State::flow && sees(ch) && hearsOf(ch))
    send(msg::EvChanHeader{hub_.channels.info(ch)});
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
