// SPDX-License-Identifier: Apache-2.0
// TLS as a layer over another transport (TCP): received ciphertext is decrypted into the
// receiver's buffer, so that the receiver sees what a plain connection would have read; writes
// are encrypted as they are given and the ciphertext written in order. Internal to the runtime.
//
// A server session refuses a peer that speaks plain (it is sent ListenOptions::plain_peer_reply
// as it is) and one whose handshake or records fail (it is sent the alert): the receiver hears
// TransportEnd::Why::refused. A client session does its handshake first (handshake()), for the
// dialer, which hands the transport over once it is established.
#pragma once

#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop_handles.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace skr::flow::transport {

class TlsTransport final : public Transport, private Transport::Receiver {
 public:
  TlsTransport(Loop& loop, std::unique_ptr<Transport> below, TlsSession session, bool server,
               std::string plain_peer_reply = {});
  ~TlsTransport() override;

  // Client: reads and writes until the handshake is done, then pauses; `done` gets nothing
  // (established) or why it failed, from the loop. Bytes that came with the handshake's end are
  // delivered once start() is called.
  void handshake(std::function<void(std::optional<TransportEnd>)> done);
  // A session another loop's transport gave up (detach()), established, over `below` here.
  [[nodiscard]] static std::unique_ptr<TlsTransport> adopted(Loop& loop,
                                                             std::unique_ptr<Transport> below,
                                                             TlsSession session, bool server);

  [[nodiscard]] TransportKind kind() const noexcept override { return TransportKind::tls; }
  [[nodiscard]] Result<void> start(Transport::Receiver& receiver) override;
  void pause() noexcept override;
  [[nodiscard]] Result<void> resume() override;
  [[nodiscard]] Result<size_t> tryWrite(std::span<const std::string_view> buffers) override;
  [[nodiscard]] Result<void> write(std::span<const std::string_view> buffers) override;
  void close(std::string_view reason) noexcept override;
  [[nodiscard]] PeerIdentity peer() const override;
  [[nodiscard]] Result<Detached> detach() override;

 private:
  // The layer below's receiver.
  std::span<char> readBuffer() override;
  void received(size_t n) override;
  void message(std::string_view) override {}
  void written(Result<void> result) override;
  void ended(const TransportEnd& end) override;
  void closed() noexcept override;

  void end(TransportEnd why);
  void deliver();  // plaintext into rx_
  [[nodiscard]] Result<void> encrypt(std::span<const std::string_view> buffers);
  [[nodiscard]] Result<void> sendNow();  // what the layer below takes now
  [[nodiscard]] Result<void> pump();     // the rest, as a write below

  std::unique_ptr<Transport> below_;
  TlsSession session_;
  Transport::Receiver* rx_ = nullptr;
  std::function<void(std::optional<TransportEnd>)> handshake_done_;
  std::unique_ptr<char[]> cipher_in_;
  std::string cipher_out_;   // encrypted, not handed below yet
  std::string cipher_wire_;  // being written below
  std::string plain_reply_;
  Timer later_;  // deliver() after start(); a write with nothing to send
  bool server_;
  bool first_input_ = true;
  bool below_writing_ = false;
  bool user_write_ = false;  // a write() waits for its ciphertext to leave
  bool ended_ = false;
  bool refused_ = false;  // no close_notify after a refusal
  bool closing_ = false;
};

}  // namespace skr::flow::transport
