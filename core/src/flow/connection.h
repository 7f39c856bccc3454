// SPDX-License-Identifier: Apache-2.0
// One satellite connected over a transport (skrobot/runtime/flow/transport.h: Unix socket, TCP,
// TLS on TCP, or a message-based one): its session with the hub. Receives bytes into a buffer that
// frames are parsed from in place (a message-based transport's messages are one frame each), checks
// each frame against the catalogue and the session's state (login, authenticating, sync, flow) and
// hands it to its room (dispatch.h); keeps an output queue flushed once per loop iteration (many
// frames per write). The rooms answer through the calls below. Main loop thread only.
#pragma once

#include "endpoint.h"
#include "frame_input.h"
#include "output.h"
#include "rate_caps.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/bytes.h>
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/log.h>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

namespace skr::flow {

struct Hub;
class Connection;

// The connection with endpoint id `id` in `hub`, if it is still there.
[[nodiscard]] Connection* connectionOf(Hub& hub, uint32_t id) noexcept;

class Connection final : public Endpoint, private transport::Transport::Receiver {
 public:
  enum class State { login, authenticating, sync, flow, closing };

  // Takes over an accepted transport; startReading() starts the session.
  Connection(Hub& hub, std::unique_ptr<transport::Transport> transport);
  ~Connection() override;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  Connection(Connection&&) = delete;
  Connection& operator=(Connection&&) = delete;

  // --- the transport (server.cpp accepts it)
  void startReading();
  // Closes now: the connection leaves every room at once; memory goes once the transport closed.
  void close(const char* why) noexcept;
  // Sends what is queued, then closes.
  void closeAfterFlush(const char* why);
  void flush();

  [[nodiscard]] Hub& hub() noexcept { return hub_; }
  [[nodiscard]] State state() const noexcept { return state_; }
  // What the accounts' rules see: a Unix socket, WebSocket (from loopback or not), or the
  // network (TCP, TLS, any other). Set at accept from the transport's peer.
  [[nodiscard]] Transport transport() const noexcept { return login_transport_; }
  // The peer's numeric address (TCP, TLS, WebSocket); empty on a Unix socket.
  [[nodiscard]] std::string peerAddress() const { return transport_->peer().address; }
  [[nodiscard]] transport::TransportKind transportKind() const noexcept {
    return transport_->kind();
  }
  Nanos login_deadline = 0;
  // Accepted beyond server.max_connections: its LOGIN is answered limit_exceeded, then it closes.
  bool over_limit = false;
  bool flush_queued = false;
  // Where it comes from, for the login throttle: "tcp:<address>" or "uid:<n>" (set at accept).
  std::string source;
  // A serial port's board logs in as the account its port is bound to, without a password.
  std::string bound_account;

  // --- the session's steps (the session room decides them)
  // LOGIN read: values are sent in `enc`; reading pauses until the password is checked.
  void authenticating(ValueEncoding enc);
  // The login succeeded (user and rules set): the connection's minor is `minor`, frames may be as
  // large as the hub's limit, and it is a synchronous connection.
  void loggedIn(uint16_t minor);
  // GO_ASYNC: it is a flow now.
  void becomeFlow();
  // SESSION_LIMITS (1.12): frames above `max_frame` (0: none) are never sent to it; channel events
  // only about its own channels, its subscriptions and those `watch` selects, unless
  // `channel_events`.
  void limitSession(uint32_t max_frame, bool channel_events, NameFilter watch);
  // The data it may wait to be sent before its oldest data frames are dropped (newest wins);
  // server.subscriber_queue_bytes unless the transport's listener set a smaller one (a serial
  // line), which SUBSCRIBE_QUEUE does not raise.
  void limitQueue(size_t bytes) noexcept {
    base_queue_ = bytes;
    queue_fixed_ = true;
    resizeQueue();
  }
  // SUBSCRIBE_QUEUE (1.13): the subscription to `chan_id` asks for `bytes` of queue (0: the
  // default). Clamped to server.subscriber_queue_max_bytes (to the listener's queue after
  // limitQueue); returns what it was granted. The queue, one for the connection, is the larger
  // of the default and every grant of a subscription it still holds.
  size_t askQueue(uint16_t chan_id, size_t bytes);
  // SUBSCRIBE_RATE (1.14): at most `max_hz` frames a second of `chan_id` reach it, newest wins
  // (rate_caps.h); 0: no cap.
  void capRate(uint16_t chan_id, uint16_t max_hz);
  // The subscription to `chan_id` ended (unsubscribed, or the channel went): its grant and its
  // rate cap go.
  void releaseQueue(uint16_t chan_id);
  // Whether channel events about `ch` reach it (always, unless it limited its session).
  [[nodiscard]] bool hearsOf(const Channel& ch) const;
  // Whether it watches channels by name (SESSION_LIMITS with a watch and no channel events).
  [[nodiscard]] bool watches() const noexcept { return !channel_events_ && !watch_.empty(); }
  // Frames not sent because they were above its SESSION_LIMITS frame limit.
  uint64_t frames_too_large = 0;

  // --- answers, for the rooms
  template <class M>
  void send(const M& m) {
    std::string& out = output_.queue();
    const size_t before = out.size();
    if (!encode(out, m, enc_)) {
      log::error(kLogSource, "FLOW-INTERNAL", describe() + ": a field exceeds its wire limit");
    }
    if (max_frame_ != 0 && out.size() - before > max_frame_) {
      out.resize(before);
      tooLarge(M::code == Code::reply_ok || M::code == Code::reply_error);
      return;
    }
    ++traffic.messages_out;
    traffic.bytes_out += out.size() - before;
    queued();
  }
  void replyOk();
  void replyError(ErrorCode error, const std::string& message);
  // REPLY_OK, or REPLY_ERROR with the error's code and message.
  void reply(const Result<void>& r);
  // A value (REPLY_OK with it), or the error.
  void replyValue(Result<Variant>&& r);
  // On a flow: EV_ERROR for `command` with its tag when `r` failed; nothing when it succeeded.
  void refused(Code command, uint32_t tag, uint16_t chan_id, const Result<void>& r);
  // A peer that breaks the protocol: FLOW-PROTOCOL logged, the connection closed.
  void protocolError(const std::string& why);
  // Pauses reading until the pending reply is sent (synchronous requests answer in order).
  void block();
  void unblock();
  // Replies to a paused request with `r` and resumes reading.
  void answerDone(const Result<void>& r);
  // A callback for another thread's work (the store, the journal, a linked hub) that finds this
  // connection again, if it is still there, and hands it the result. whenDone and whenRead for
  // the two results there are.
  template <class R>
  std::function<void(R)> whenAlive(std::function<void(Connection&, R)> then);
  std::function<void(Result<void>)> whenDone(std::function<void(Connection&, Result<void>)> then);
  std::function<void(Result<Variant>)> whenRead(
      std::function<void(Connection&, Result<Variant>)> then);

  // --- a pipeline of requests answered later, in order (blob requests)
  // A request the connection goes on reading past: `then` answers it when the work is done (if
  // the connection is still there). Until every answer of the pipeline has left, a request of
  // another family waits (answers keep the order of the requests). `bytes`: what it carries or
  // asks for, counted until the answer.
  template <class T>
  std::function<void(Result<T>)> pipelined(uint64_t bytes,
                                           std::function<void(Connection&, Result<T>&)> then);
  [[nodiscard]] uint32_t pipelineDepth() const noexcept { return pipeline_in_flight_; }
  [[nodiscard]] uint64_t pipelineBytes() const noexcept { return pipeline_bytes_; }
  // Enough in the hub for this connection: reading pauses until an answer of the pipeline leaves.
  void pausePipeline();

  // --- bulk data, for the blobs room
  // The bytes `part` of the frame being handled, for another thread: a large one takes the read
  // buffer with it (no copy on the loop thread; what follows the frame moves to a new buffer), a
  // small one is copied.
  SharedBytes takeBody(std::string_view part);
  // BLOB_DATA around bytes read after the header's room in `frame`: the header is written in
  // front of them, and the buffer becomes the output queue's when that is empty (no copy).
  void sendBlobData(uint64_t version, uint64_t total_size, std::string frame);
  // A Unix socket's send buffer, raised once the connection downloads files: the kernel's
  // default (about 200 KiB) makes a write, and a wake-up of each side, per 200 KiB. TCP tunes
  // its own. Only synchronous connections download, so no sync pulse waits behind it.
  void widenSendBuffer();

  // Endpoint
  [[nodiscard]] bool receivesEvents() const override { return state_ == State::flow; }
  [[nodiscard]] bool congested() const override;
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] const char* kind() const override {
    return !linked_hub.empty() ? "link" : state_ == State::sync ? "sync" : "satellite";
  }
  [[nodiscard]] size_t queuedBytes() const override { return output_.bytes(); }
  [[nodiscard]] size_t queueLimitBytes() const override { return queue_limit_; }
  [[nodiscard]] RateCap rateCap(uint16_t chan) const override;
  void onData(const Channel& ch, std::string_view payload) override;
  void onSubscribers(const Channel& ch, bool first) override;
  void onRequest(const Channel& ch, uint64_t request, const std::string& command,
                 const std::string& requester, const Variant& value) override;
  void onResponse(uint16_t chan_id, uint32_t tag, bool sync, ErrorCode error,
                  const Variant& value) override;
  void onChannelAdded(const Channel& ch, uint32_t tag) override;
  void onChannelRemoved(const Channel& ch) override;
  void onChannelHeader(const Channel& ch) override;
  void onSyncPulse(const Channel& ch, uint64_t seq, uint64_t source_time_ns,
                   uint32_t dropped) override;
  void onPhysical(const msg::EvPhysGrant& m) override;
  void onPhysical(const msg::EvPhysPath& m) override;
  void onPhysical(const msg::EvPhysRevoke& m) override;
  void onPhysical(const msg::EvPhysRelay& m) override;
  void onPhysical(const msg::EvPhysSwitch& m) override;
  void onPhysical(const msg::EvPhysResume& m) override;
  void onPhysical(const msg::EvPhysMarker& m) override;
  [[nodiscard]] uint16_t protocolMinor() const override { return minor_; }
  void onError(Code command, uint32_t tag, uint16_t chan_id, ErrorCode error,
               const std::string& message) override;
  void onDbChanged(const std::string& name) override;
  void onBlobChanged(const Channel& ch, const BlobEvent& event) override;
  // False for a channel of a kind newer than the connection's minor (blob channels before 1.3).
  [[nodiscard]] bool sees(const Channel& ch) const noexcept;

 private:
  // Transport::Receiver
  std::span<char> readBuffer() override;
  void received(size_t n) override;
  void message(std::string_view bytes) override;
  void written(Result<void> result) override;
  void ended(const transport::TransportEnd& end) override;
  void closed() noexcept override;

  void processInput();
  // Blocks of whole frames from an I/O thread (io_relay.h), once the connection moved there.
  void relayedInput(FrameInput::Block block);
  // A synchronous connection's first blob request: its socket moves to an I/O thread
  // (io_relay.h) before the request is handled, there or here (a kind that cannot move, TLS).
  [[nodiscard]] bool movesToIoThread(uint8_t code) const;
  void startMove();
  void finishMove();
  // A frame: checked against the catalogue and the session's state, then dispatched.
  void handleFrame(uint8_t code, std::string_view body);
  void dispatchFrame(uint8_t code, std::string_view body);
  // Before handling a frame: a request of another family than the pipeline's waits until the
  // pipeline's answers have left. True when it must wait.
  bool waitForPipeline(uint8_t code);
  // The answer at `place` in the pipeline: sent when every answer before it has left, else held
  // until then (a far hub's answer may come before the store's to an earlier request).
  void pipelineAnswer(uint64_t place, uint64_t bytes, std::function<void(Connection&)> answer);
  void pipelineAnswered(uint64_t bytes);

  void queued();  // after queueing output: limits, then flush scheduling
  // A frame above the session's limit was not sent: counted; a reply becomes REPLY_ERROR.
  void tooLarge(bool reply);
  // A frame that goes ahead of the output queued in the hub (a sync pulse): after the slice being
  // written, before everything else.
  void sendUrgent(std::string_view frame);
  void dropOldestData(size_t needed);
  // An EV_DATA frame onto the output queue (dropping the oldest when full).
  void queueData(const Channel& ch, std::string_view payload);
  void resizeQueue() noexcept;  // queue_limit_ from base_queue_ and queue_asked_
  // Fair turns: processInput handled kFramesPerTurn frames or kBytesPerTurn bytes: reading pauses
  // and the rest is handled from a post, after the loop served the others (resumeTurn).
  void yieldTurn();
  void resumeTurn();

  Hub& hub_;
  std::unique_ptr<transport::Transport> transport_;
  Transport login_transport_ = Transport::tcp;
  State state_ = State::login;
  uint16_t minor_ = 0;  // the connection's protocol minor: the lower of the client's and ours
  ValueEncoding enc_ = ValueEncoding::binary;
  FrameInput input_;               // received bytes, frames split from them
  bool blocked_ = false;           // a sync reply is pending: do not parse further frames
  bool yielding_ = false;          // its turn's budget is spent: the rest waits for a post
  bool moving_ = false;            // its socket is moving to an I/O thread: frames wait
  bool move_after_write_ = false;  // ... once the write under way is done
  bool stays_ = false;             // it moved, or cannot: it is not asked again
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);  // a post's weak token of it
  uint32_t pipeline_in_flight_ = 0;  // pipelined requests in the hub, not answered yet
  uint64_t pipeline_bytes_ = 0;      // the data they carry or ask for
  Family pipeline_family_ = Family::blobs;
  uint64_t pipeline_next_ = 0;  // the place of the next pipelined request
  uint64_t pipeline_sent_ = 0;  // the place of the next answer to leave
  struct Held {
    uint64_t bytes = 0;
    std::function<void(Connection&)> answer;
  };
  std::map<uint64_t, Held> pipeline_held_;  // answers that came early, by place
  bool pipeline_waiting_ = false;           // reading paused until a pipelined answer leaves
  uint8_t current_code_ = 0;                // the code of the frame being handled
  bool wide_send_buffer_ = false;           // widened for downloads (widenSendBuffer)
  bool reading_ = false;
  bool reading_started_ = false;  // the transport was started (later: resume)

  Output output_;
  size_t base_queue_;   // server.subscriber_queue_bytes, or the listener's (limitQueue)
  size_t queue_limit_;  // data frames wait up to this many bytes (resizeQueue)
  std::map<uint16_t, size_t> queue_asked_;  // SUBSCRIBE_QUEUE grants by channel
  std::unique_ptr<RateCaps> rates_;         // SUBSCRIBE_RATE caps (from the first one)
  bool queue_fixed_ = false;                // the listener's queue (limitQueue): not raised
  uint32_t max_frame_ = 0;                  // SESSION_LIMITS: the largest frame sent to it; 0 none
  bool channel_events_ = true;
  NameFilter watch_;
  bool close_after_flush_ = false;
  std::map<uint16_t, uint32_t> dropped_;  // per channel since the last EV_DROPPED
  Nanos last_drop_log_ = 0;
};

// --- templates ------------------------------------------------------------------------------

template <class R>
std::function<void(R)> Connection::whenAlive(std::function<void(Connection&, R)> then) {
  return [&hub = hub_, my_id = id, then = std::move(then)](R r) {
    if (Connection* c = connectionOf(hub, my_id)) then(*c, std::move(r));  // else gone meanwhile
  };
}

template <class T>
std::function<void(Result<T>)> Connection::pipelined(
    uint64_t bytes, std::function<void(Connection&, Result<T>&)> then) {
  if (pipeline_in_flight_ == 0) {
    const CodeInfo* info = codeInfo(current_code_);
    pipeline_family_ = info != nullptr ? info->family : Family::blobs;
  }
  ++pipeline_in_flight_;
  pipeline_bytes_ += bytes;
  return [&hub = hub_, my_id = id, place = pipeline_next_++, bytes,
          then = std::move(then)](Result<T> r) mutable {
    Connection* c = connectionOf(hub, my_id);
    if (c == nullptr) return;
    c->pipelineAnswer(
        place, bytes,
        [then = std::move(then), r = std::move(r)](Connection& c) mutable { then(c, r); });
  };
}

}  // namespace skr::flow
