// SPDX-License-Identifier: Apache-2.0
// One connection to a hub (internal to the satellite library): opens a transport to the hub's
// address (skrobot/runtime/flow/transport.h: Unix socket, TCP, TLS on TCP), splits the bytes it
// receives into frames, and writes everything queued during one loop iteration in one write.
//
// Loop thread only. A Link is heap-allocated by open() and deletes itself once its transport has
// closed: after close() by the owner (no callback follows), or after reporting a failure through
// Handler::onLinkClosed (the owner must forget the pointer there, and not call close()).
#pragma once

#include "frame_input.h"

#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop_handles.h>
#include <skrobot/satellite/address.h>

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace skr::sat::detail {

// A hub that closes the connection while we write must not kill the process (SIGPIPE's default
// action): the write fails with EPIPE and the satellite reconnects. Sets SIGPIPE to ignored once,
// and only when the process left it at its default. Called by every Link.
void ignoreSigpipe();

class Link final : private flow::transport::Transport::Receiver {
 public:
  class Handler {
   public:
    virtual void onLinkConnected() = 0;
    // A frame; `body` is valid during the call only. The handler may close() the link here.
    virtual void onLinkFrame(uint8_t code, std::string_view body) = 0;
    // The link failed (never called from inside open() or close()); `protocol` when the hub sent
    // a frame whose length breaks the protocol. The Link deletes itself after this returns.
    virtual void onLinkClosed(const std::string& why, bool protocol) = 0;

   protected:
    Handler() = default;
    ~Handler() = default;
    Handler(const Handler&) = default;
    Handler& operator=(const Handler&) = default;
    Handler(Handler&&) = default;
    Handler& operator=(Handler&&) = default;
  };

  // Starts connecting; failures come later through onLinkClosed. `dial.tls` is required for a
  // tls: address (its failure is reported as the link's), the udp_ settings for a udp: one.
  [[nodiscard]] static Link* open(Loop& loop, const Address& address,
                                  const flow::transport::DialOptions& dial,
                                  uint32_t max_frame_bytes, Handler& handler);
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;
  Link(Link&&) = delete;
  Link& operator=(Link&&) = delete;

  // Drops queued output and closes; no callback follows.
  void close() noexcept;

  // Appends frames to `out()`, then calls queued(): the bytes leave at the end of this loop
  // iteration, together with everything else queued meanwhile.
  [[nodiscard]] std::string& out() noexcept { return out_; }
  void queued();
  [[nodiscard]] size_t pendingBytes() const noexcept { return out_.size() + inflight_.size(); }
  [[nodiscard]] uint64_t writes() const noexcept { return writes_; }

 private:
  enum class State { connecting, open, failed, closed };
  Link(Loop& loop, const Address& address, uint32_t max_frame_bytes, Handler& handler);
  ~Link() = default;

  void opened(Result<std::unique_ptr<flow::transport::Transport>> transport);
  void fail(std::string why, bool protocol = false);
  void flush();
  void processInput();

  // Transport::Receiver
  std::span<char> readBuffer() override { return input_.room(); }
  void received(size_t n) override;
  void message(std::string_view bytes) override;  // one whole frame (a serial line's)
  void written(Result<void> result) override;
  void ended(const flow::transport::TransportEnd& end) override;
  void closed() noexcept override { delete this; }

  Loop& loop_;
  Address address_;
  Handler& handler_;
  std::unique_ptr<flow::transport::Dialer> dialer_;
  std::unique_ptr<flow::transport::Transport> transport_;
  flow::FrameInput input_;
  Timer turn_;  // at the end of this loop iteration: flush, or report the failure
  State state_ = State::connecting;
  bool writing_ = false;
  std::string failure_;
  bool failure_protocol_ = false;

  std::string out_;       // queued, not yet handed to the transport
  std::string inflight_;  // being written
  uint64_t writes_ = 0;
};

}  // namespace skr::sat::detail
