// SPDX-License-Identifier: Apache-2.0
// One session of a message-framed carrier (a serial line, a UDP port): a Transport with one whole
// frame per message (Framing::messages), over a carrier that sends and receives frames for it.
// What every such session shares lives here: frames received while the receiver is paused (kept
// up to a limit), writes handed to the carrier in whole frames (a write waits while the carrier
// has no room), the end of the carrier, close(), and every callback from the loop, never from
// inside a call (transport.h).
//
// A carrier derives its session from this class: sendFrame() hands one frame to it, leaveCarrier()
// makes it forget the session. The carrier calls received(), carrierEnded() and carrierRoom().
// The derived class's destructor calls leave() (the base cannot: leaveCarrier is virtual).
//
// Used by the serial line (runtime/src/transport/serial_port.cpp), the hub's UDP port
// (core/src/flow/udp_port.cpp) and the client's UDP session (runtime/src/transport/udp_client.cpp).
// Thread: the loop's, as every transport.
#pragma once

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop_handles.h>

#include <deque>
#include <optional>
#include <string>

namespace skr::flow::transport {

class MessageSession : public Transport {
 public:
  // `ended_text`: what a write after the end says ("the serial session ended").
  // `pending_bytes`: the frames a paused session keeps at most; more are dropped (received()).
  MessageSession(Loop& loop, TransportKind kind, PeerIdentity peer, uint32_t max_frame,
                 size_t pending_bytes, std::string ended_text);
  ~MessageSession() override = default;

  [[nodiscard]] TransportKind kind() const noexcept override { return kind_; }
  [[nodiscard]] Framing framing() const noexcept override { return Framing::messages; }
  [[nodiscard]] Result<void> start(Receiver& receiver) override;
  void pause() noexcept override { paused_ = true; }
  [[nodiscard]] Result<void> resume() override;
  [[nodiscard]] Result<size_t> tryWrite(std::span<const std::string_view> buffers) override;
  [[nodiscard]] Result<void> write(std::span<const std::string_view> buffers) override;
  void close(std::string_view reason) noexcept override;
  [[nodiscard]] PeerIdentity peer() const override { return peer_; }
  [[nodiscard]] uint32_t maxFrameBytes() const noexcept override { return max_frame_; }

  // From the carrier. One whole frame received: delivered now, or kept while the receiver is
  // paused or not started; false when it was dropped (the pending limit: the carrier counts it).
  [[nodiscard]] bool received(std::string_view frame);
  // The carrier lets go of this session (it must not be called into again): the frames not
  // delivered yet are dropped, and the receiver hears `end` from the loop.
  void carrierEnded(TransportEnd end);
  // The carrier has room again: a write() waiting for it goes on.
  void carrierRoom();

 protected:
  // Hands one whole frame (length prefix included) to the carrier: false when it has no room
  // now (the frame is offered again after carrierRoom()). Only while the session is attached.
  virtual bool sendFrame(std::string_view frame) = 0;
  // close() or destruction while attached: the carrier forgets this session, without calling
  // received(), carrierEnded() or carrierRoom() from inside this call.
  virtual void leaveCarrier() noexcept = 0;
  // Leaves the carrier if still attached. Derived destructors call it.
  void leave() noexcept;
  [[nodiscard]] bool attached() const noexcept { return attached_; }

 private:
  // Hands the whole frames of `bytes` to the carrier while it takes them: the bytes taken.
  size_t toCarrier(std::string_view bytes);
  void deliver();

  TransportKind kind_;
  PeerIdentity peer_;
  uint32_t max_frame_;
  size_t pending_limit_;
  std::string ended_text_;
  Receiver* receiver_ = nullptr;
  bool attached_ = true;
  bool paused_ = false;
  bool closing_ = false;
  std::deque<std::string> pending_;  // frames received while paused
  size_t pending_bytes_ = 0;
  std::optional<TransportEnd> end_;
  std::string writing_;  // what write() was given and the carrier has not taken yet
  size_t written_off_ = 0;
  bool write_under_way_ = false;
  bool written_due_ = false;
  Timer later_;  // callbacks from the loop, never from inside a call
};

}  // namespace skr::flow::transport
