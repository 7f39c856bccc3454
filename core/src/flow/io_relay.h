// SPDX-License-Identifier: Apache-2.0
// Synchronous connections served on I/O threads (docs/internals.md, "Threads"): once a
// synchronous connection sends its first blob request, its socket (Unix, TCP, or TLS with its
// session) moves to an I/O thread, which reads and splits its frames and writes its output (and
// decrypts and encrypts a TLS session's records). The Connection stays on the main loop with
// everything it knows (the session, the rights, the blob pipeline); its transport becomes a
// RelayTransport, whose input arrives as blocks of whole frames (moved, not copied: a blob
// chunk's bytes are read once, on the I/O thread, and reach the store as they are) and whose
// writes are done over there (a download's data is never copied or written on the main loop).
//
//   IoThread         one I/O thread: a loop of its own; stop() ends every connection it serves.
//   RelayTransport   the main loop's end of a moved connection: a Transport whose input comes in
//                    blocks of whole frames (to a function the Connection gives), in order, held
//                    while paused; at most kWindow bytes wait for the main loop, then the I/O
//                    thread stops reading the socket.
//
// Threads: an IoThread is made and stopped on the main thread; a RelayTransport lives on the main
// loop like any transport. What crosses is posted to the I/O loop, or put into the relay's inbox
// and signalled with a uv_async of the main loop (so that the close, which the Connection's life
// ends with, is a libuv close callback there as for every other transport).
#pragma once

#include "frame_input.h"

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop.h>

#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>

struct uv_async_s;

namespace skr::flow {

struct RelayShared;

class IoThread {
 public:
  explicit IoThread(std::string name);
  ~IoThread();  // stop()
  IoThread(const IoThread&) = delete;
  IoThread& operator=(const IoThread&) = delete;
  IoThread(IoThread&&) = delete;
  IoThread& operator=(IoThread&&) = delete;

  // Runs `fn` on the I/O thread; false (not run) once stopping.
  bool post(std::function<void()> fn);
  // Closes the sockets of every connection it still serves (their relays hear that they closed),
  // then stops the thread. Idempotent.
  void stop() noexcept;

  [[nodiscard]] Loop& loop() noexcept { return thread_.loop(); }
  // The relays it serves (I/O thread only).
  std::set<RelayShared*> serving;

 private:
  std::mutex mutex_;
  bool stopped_ = false;
  LoopThread thread_;
};

class RelayTransport final : public transport::Transport {
 public:
  // Whole frames for the connection, in order.
  using Frames = std::function<void(FrameInput::Block)>;
  static constexpr size_t kWindow = size_t{16} << 20;

  // Moves `detached` to `io`: `unread` (bytes the connection received and did not handle, from a
  // frame's start) is split there with what follows; frames above `max_frame_bytes` are refused
  // as on the main loop (handed over for the connection to report).
  RelayTransport(Loop& main, std::shared_ptr<IoThread> io, transport::Detached detached,
                 FrameInput::Block unread, uint32_t max_frame_bytes, Frames frames);
  ~RelayTransport() override;

  [[nodiscard]] transport::TransportKind kind() const noexcept override { return kind_; }
  // Written in whole frames (Output hands a download's 4 MiB frame over in one write rather than
  // in slices, each a round trip between the threads); a synchronous connection has no urgent
  // frame to put between slices.
  [[nodiscard]] Framing framing() const noexcept override { return Framing::frame_messages; }
  [[nodiscard]] Result<void> start(Receiver& receiver) override;
  void pause() noexcept override;
  [[nodiscard]] Result<void> resume() override;
  // Never takes bytes directly: the write is the I/O thread's (0, then write()).
  [[nodiscard]] Result<size_t> tryWrite(std::span<const std::string_view> buffers) override;
  [[nodiscard]] Result<void> write(std::span<const std::string_view> buffers) override;
  void close(std::string_view reason) noexcept override;
  [[nodiscard]] transport::PeerIdentity peer() const override { return peer_; }

 private:
  static void onWake(uv_async_s* handle);
  void drain();
  void closeNow() noexcept;  // the I/O thread let go of the socket: closed() follows

  Loop& main_;
  std::shared_ptr<IoThread> io_;
  std::shared_ptr<RelayShared> shared_;
  transport::TransportKind kind_;
  transport::PeerIdentity peer_;
  Frames frames_;
  Receiver* receiver_ = nullptr;
  bool paused_ = false;
  bool closing_ = false;
  bool closed_ = false;
};

}  // namespace skr::flow
