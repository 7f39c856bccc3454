// SPDX-License-Identifier: Apache-2.0
#include "tls_transport.h"

#include <skrobot/runtime/log.h>

namespace skr::flow::transport {
namespace {

constexpr size_t kCipherChunk = size_t{64} * 1024;

}  // namespace

TlsTransport::TlsTransport(Loop& loop, std::unique_ptr<Transport> below, TlsSession session,
                           bool server, std::string plain_peer_reply)
    : below_(std::move(below)),
      session_(std::move(session)),
      cipher_in_(std::make_unique_for_overwrite<char[]>(kCipherChunk)),
      plain_reply_(std::move(plain_peer_reply)),
      later_(loop,
             [this] {
               if (user_write_ && !below_writing_ && cipher_out_.empty()) {
                 user_write_ = false;
                 rx_->written({});
               }
               deliver();
             }),
      server_(server) {}

TlsTransport::~TlsTransport() = default;

void TlsTransport::handshake(std::function<void(std::optional<TransportEnd>)> done) {
  handshake_done_ = std::move(done);
  if (auto r = below_->start(*this); !r) {
    end({TransportEnd::Why::error, r.error().message});
    return;
  }
  if (auto r = sendNow(); !r) end({TransportEnd::Why::error, r.error().message});  // ClientHello
}

std::unique_ptr<TlsTransport> TlsTransport::adopted(Loop& loop, std::unique_ptr<Transport> below,
                                                    TlsSession session, bool server) {
  auto t = std::make_unique<TlsTransport>(loop, std::move(below), std::move(session), server);
  t->first_input_ = false;  // its first bytes were read on the other loop
  return t;
}

Result<void> TlsTransport::start(Transport::Receiver& receiver) {
  rx_ = &receiver;
  // What came with the handshake's last records (a client), or what a moved session decrypted.
  if (!server_ || !first_input_) later_.startIn(0);
  return below_->start(*this);
}

Result<Detached> TlsTransport::detach() {
  if (closing_ || ended_) return makeError(Errc::closed, "closed");
  if (!session_.established())
    return makeError(Errc::invalid_argument, "the TLS handshake is under way");
  session_.takeOutput(cipher_out_);
  if (below_writing_ || user_write_ || !cipher_out_.empty()) {
    return makeError(Errc::invalid_argument, "a write is under way");
  }
  PeerIdentity who = peer();
  auto below = below_->detach();
  if (!below) return below.error();
  later_.stop();
  closing_ = true;  // nothing more here; the session lives on in the other loop's transport
  rx_ = nullptr;
  return Detached(below->release(), std::move(who), std::move(session_), server_);
}

void TlsTransport::pause() noexcept {
  below_->pause();
}

Result<void> TlsTransport::resume() {
  return below_->resume();
}

std::span<char> TlsTransport::readBuffer() {
  return {cipher_in_.get(), kCipherChunk};
}

void TlsTransport::received(size_t n) {
  const std::string_view cipher(cipher_in_.get(), n);
  if (server_ && first_input_ && !looksLikeTls(cipher)) {
    // A plain FlowProtocol client: it waits for the reply to its LOGIN, so it is told in its
    // own language before the connection closes (one try on a fresh socket: no queueing).
    if (!plain_reply_.empty()) {
      const std::string_view reply = plain_reply_;
      (void)below_->tryWrite({&reply, 1});
    }
    end({TransportEnd::Why::refused, "a plain TCP client on the TLS port"});
    return;
  }
  first_input_ = false;
  const bool was_established = session_.established();
  if (auto r = session_.receive(cipher); !r) {
    // Tell the peer why (an alert: unknown CA, bad certificate...), so that its log says it too.
    std::string alert;
    session_.takeOutput(alert);
    if (!alert.empty() && !below_writing_) {
      const std::string_view a = alert;
      (void)below_->tryWrite({&a, 1});
    }
    end({TransportEnd::Why::refused, r.error().message});
    return;
  }
  if (auto r = sendNow(); !r) {  // handshake records
    end({TransportEnd::Why::error, r.error().message});
    return;
  }
  if (!was_established && session_.established()) {
    if (server_) {
      log::debug("flow", "FLOW-TLS", "tls " + below_->peer().source() + ": " + session_.describe());
    }
    if (handshake_done_) {
      below_->pause();
      auto done = std::move(handshake_done_);
      handshake_done_ = nullptr;
      done(std::nullopt);
      return;
    }
  }
  deliver();
}

void TlsTransport::deliver() {
  while (rx_ != nullptr && !ended_ && !closing_ && session_.established()) {
    const std::span<char> room = rx_->readBuffer();
    auto got = session_.read(room.data(), room.size());
    if (!got) {
      if (got.error().code == Errc::closed) {
        end({TransportEnd::Why::peer_closed, "peer closed TLS"});
      } else {
        end({TransportEnd::Why::refused, got.error().message});
      }
      return;
    }
    if (*got == 0) return;
    rx_->received(*got);  // may pause or close this transport
  }
}

void TlsTransport::end(TransportEnd why) {
  if (ended_ || closing_) return;
  ended_ = true;
  refused_ = why.why == TransportEnd::Why::refused;
  below_->pause();
  if (handshake_done_) {
    auto done = std::move(handshake_done_);
    handshake_done_ = nullptr;
    done(std::move(why));
  } else if (rx_ != nullptr) {
    rx_->ended(why);
  }
}

void TlsTransport::ended(const TransportEnd& e) {
  if (server_ && !first_input_ && !session_.established()) {
    end({TransportEnd::Why::refused, "the client closed the connection during the TLS handshake"});
    return;
  }
  end(e);
}

Result<void> TlsTransport::encrypt(std::span<const std::string_view> buffers) {
  for (const std::string_view b : buffers) {
    if (auto w = session_.write(b); !w) return w;
  }
  session_.takeOutput(cipher_out_);
  return {};
}

Result<void> TlsTransport::sendNow() {
  session_.takeOutput(cipher_out_);
  if (below_writing_ || cipher_out_.empty()) return {};
  const std::string_view c = cipher_out_;
  auto sent = below_->tryWrite({&c, 1});
  if (!sent) return sent.error();
  cipher_out_.erase(0, *sent);
  return pump();
}

Result<void> TlsTransport::pump() {
  if (below_writing_ || cipher_out_.empty()) return {};
  cipher_wire_.swap(cipher_out_);
  cipher_out_.clear();
  below_writing_ = true;
  const std::string_view c = cipher_wire_;
  if (auto r = below_->write({&c, 1}); !r) {
    below_writing_ = false;
    return r;
  }
  return {};
}

void TlsTransport::written(Result<void> result) {
  below_writing_ = false;
  cipher_wire_.clear();
  if (closing_) return;
  if (!result) {
    if (user_write_) {
      user_write_ = false;
      rx_->written(std::move(result));
    } else {
      end({TransportEnd::Why::error, result.error().message});
    }
    return;
  }
  if (!cipher_out_.empty()) {
    if (auto r = pump(); !r) end({TransportEnd::Why::error, r.error().message});
    return;
  }
  if (user_write_) {
    user_write_ = false;
    rx_->written({});
  }
}

Result<size_t> TlsTransport::tryWrite(std::span<const std::string_view> buffers) {
  if (closing_ || ended_) return makeError(Errc::io_error, "closed");
  if (below_writing_ || user_write_) return size_t{0};
  if (auto r = encrypt(buffers); !r) return r.error();
  if (auto r = sendNow(); !r) return r.error();
  size_t n = 0;
  for (const std::string_view b : buffers) n += b.size();
  return n;  // encrypted: what the socket did not take yet leaves with a write below
}

Result<void> TlsTransport::write(std::span<const std::string_view> buffers) {
  if (closing_ || ended_) return makeError(Errc::io_error, "closed");
  if (user_write_) return makeError(Errc::internal, "a write is under way");
  if (auto r = encrypt(buffers); !r) return r;
  user_write_ = true;
  if (!below_writing_ && cipher_out_.empty()) {
    later_.startIn(0);  // nothing to send (yet): done, from the loop
    return {};
  }
  if (auto r = pump(); !r) {
    user_write_ = false;
    return r;
  }
  return {};
}

void TlsTransport::close(std::string_view reason) noexcept {
  if (closing_) return;
  closing_ = true;
  later_.stop();
  if (session_.established() && !below_writing_ && !refused_) {
    // close_notify, so that the peer can tell our close from a cut connection.
    session_.shutdown();
    std::string bye;
    session_.takeOutput(bye);
    const std::string_view b = bye;
    if (!bye.empty()) (void)below_->tryWrite({&b, 1});
  }
  below_->close(reason);
}

void TlsTransport::closed() noexcept {
  if (rx_ != nullptr) rx_->closed();  // may destroy this
}

PeerIdentity TlsTransport::peer() const {
  PeerIdentity id = below_->peer();
  id.kind = TransportKind::tls;
  id.certificate = session_.peerSubject();
  return id;
}

}  // namespace skr::flow::transport
