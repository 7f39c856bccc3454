// SPDX-License-Identifier: Apache-2.0
// FlowProtocol on a serial line (a board on USB serial, a UART): the device opened raw, frames in
// the line framing of satellite/mcu/src/skr_line.h (COBS, a version byte, a CRC-16, a 0x00
// delimiter; docs/flow-protocol.md, "Serial lines"), and one session at a time over it.
//
// The hub's side is a SerialPort: a Listener that owns the device. The first frame that arrives
// while no session is open starts one, handed over as a Transport (Framing::messages) like an
// accepted connection; a LOGIN frame while a session is open ends that session (the board
// restarted) and starts the next. Closing a session leaves the device open: the port waits for
// the next one. A frame the check refuses is dropped and counted; the receiver resynchronises at
// the next delimiter, and the session does not hear of it.
//
// Thread: the loop's, as every transport (transport.h).
#pragma once
#include <skrobot/runtime/flow/transport.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace skr::flow::transport {

struct SerialOptions {
  std::string device;      // the path opened (a glob is the caller's to expand)
  uint32_t baud = 115200;  // one of the standard rates, 50 to 4000000
  // The largest frame received (longer ones are dropped and counted) and sent (larger ones are
  // the session's to keep away: SESSION_LIMITS).
  uint32_t max_frame = 4096;
  // Encoded bytes waiting for the line, at most; beyond them a session's writes wait (its
  // connection's queue then drops the oldest data: newest wins).
  uint32_t queue_bytes = 4096;
  std::string account;  // PeerIdentity::account of its sessions
  // Bytes a second the hub sends on the line at most, in bursts of kPaceBurstBytes at most; 0:
  // automatic (pacedBytesPerSecond). A board's CPU reads slower than a fast line brings bytes
  // while it encodes or checks a frame: an Uno keeps 63 bytes meanwhile (docs/microcontrollers.md,
  // "Fast lines").
  uint32_t pace = 0;
};

// The automatic pace: the line's rate (baud / 10 bytes a second), at most kBoardPaceBytesPerSecond.
inline constexpr uint32_t kBoardPaceBytesPerSecond = 50000;
inline constexpr uint32_t kPaceBurstBytes = 32;
[[nodiscard]] constexpr uint32_t pacedBytesPerSecond(const SerialOptions& o) noexcept {
  if (o.pace != 0) return o.pace;
  return o.baud / 10 < kBoardPaceBytesPerSecond ? o.baud / 10 : kBoardPaceBytesPerSecond;
}

// What went through the line, for hub.stats.
struct SerialStats {
  uint64_t bytes_in = 0, bytes_out = 0;
  uint64_t frames_in = 0, frames_out = 0;
  uint64_t bad_check = 0;    // dropped: the CRC did not match
  uint64_t bad_framing = 0;  // dropped: a COBS block cut short, an empty frame
  uint64_t bad_version = 0;  // dropped: another framing version
  uint64_t too_long = 0;     // dropped: longer than max_frame
  uint64_t overrun = 0;      // dropped: a paused session had too many frames waiting
  uint64_t dropped_out = 0;  // not sent: a frame larger than the line's queue
  uint64_t sessions = 0;     // sessions started
  // Frames dropped by the line's checks, and resynchronisations (the receiver lost its place).
  [[nodiscard]] uint64_t resyncs() const noexcept { return bad_check + bad_framing + bad_version; }
};

// Opens `device` raw (no echo, no line discipline, 8N1, no flow control) at `baud`, non-blocking.
// Errc::not_found when it does not exist, Errc::io_error with the system's reason otherwise,
// Errc::invalid_argument for a rate the system does not have.
[[nodiscard]] Result<int> openSerialDevice(const std::string& device, uint32_t baud);

// A client's end of a line (a satellite on a Linux board, `serial:` addresses): the device opened
// raw and one session over it, owning the device. Opening a tty does not wait.
[[nodiscard]] Result<std::unique_ptr<Transport>> openSerialSession(Loop& loop,
                                                                   const std::string& device,
                                                                   uint32_t baud);

class SerialPort : public Listener {
 public:
  // Why a port stopped: the device went away (unplugged) or failed.
  using Lost = std::function<void(const std::string& why)>;

  [[nodiscard]] static Result<std::unique_ptr<SerialPort>> open(Loop& loop, SerialOptions options,
                                                                Accepted accepted, Lost lost);
  [[nodiscard]] uint16_t port() const noexcept override { return 0; }
  [[nodiscard]] virtual const SerialStats& stats() const noexcept = 0;
  [[nodiscard]] virtual const SerialOptions& options() const noexcept = 0;
  // Whether a session is open now.
  [[nodiscard]] virtual bool inSession() const noexcept = 0;
};

}  // namespace skr::flow::transport
