// SPDX-License-Identifier: Apache-2.0
// A client's UDP session (udp: addresses; docs/flow-protocol.md, "UDP"): one socket connected to
// the hub's server.udp port, the board's handshake with the account's key (the board library's
// own C: satellite/mcu/src/skr_udp_wire.h, compiled into the runtime), then a MessageSession
// with one whole frame per DATA datagram. The dialer (dialer.cpp) resolves the name off the loop
// thread and hands the address here.
//
// The session has no keep-alive of its own (the wire has none): the satellite library sends a
// TIME_PROBE every 2 s on a udp: flow, so that the hub's session_timeout_ms never passes, and the
// session ends when nothing came from the hub for DialOptions::udp_silence_ms.
//
// Thread: the loop's, as every transport.
#pragma once

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop_handles.h>

#include "message_session.h"
#include "skr_udp_wire.h"

#include <sys/socket.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skr::flow::transport {

class UdpClientSession final : public MessageSession {
 public:
  // Why a handshake failed: Why::refused when the system says the port is closed (an ICMP
  // answer: the dialer tries the next address), Why::error for the time-out.
  using Handshaken = std::function<void(std::optional<TransportEnd> failed)>;

  // A socket connected to `to` (nothing sent yet). Errc::io_error with the system's reason.
  [[nodiscard]] static Result<std::unique_ptr<UdpClientSession>> open(Loop& loop,
                                                                      const sockaddr_storage& to,
                                                                      socklen_t to_len,
                                                                      const DialOptions& options);
  ~UdpClientSession() override;

  // HELLO, COOKIE, OPEN, ACCEPT; `done` is called once, from the loop.
  void handshake(Handshaken done);

  UdpClientSession(Loop& loop, int fd, PeerIdentity peer, const DialOptions& options);

 private:
  enum class Step { idle, hello, open, session, ended };

  bool sendFrame(std::string_view frame) override;
  void leaveCarrier() noexcept override;

  void onEvents(unsigned events);
  void read();
  void datagram(const uint8_t* d, size_t n);
  void resend();
  void checkSilence();
  void handshakeOver(std::optional<TransportEnd> failed);
  // The session is over from this side or the hub's: the socket closes, the receiver hears `end`.
  void endSession(TransportEnd end);
  void closeSocket() noexcept;

  int fd_;
  std::string user_;
  uint32_t handshake_ms_;
  uint32_t max_datagram_;
  uint32_t silence_ms_;
  skr_udp_session wire_{};
  std::vector<uint8_t> tx_;  // the datagram being sent
  Step step_ = Step::idle;
  std::string out_;  // the HELLO or OPEN sent again until answered
  bool cookie_seen_ = false;
  Nanos last_in_ = 0;
  bool warned_too_large_ = false;
  Handshaken done_;
  FdWatch watch_;
  Timer resend_;    // the handshake's repeats
  Timer deadline_;  // the handshake's end
  Timer silence_;   // once a second while the session is open
  Timer report_;    // the handshake's outcome, from the loop
  std::optional<TransportEnd> failed_;
};

}  // namespace skr::flow::transport
