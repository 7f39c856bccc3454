// SPDX-License-Identifier: Apache-2.0
// TLS for FlowProtocol connections over TCP, with OpenSSL, through memory buffers: the caller owns
// the socket (a libuv stream or a blocking fd), hands received bytes in and sends what comes out,
// so an event loop never blocks inside OpenSSL. No OpenSSL type appears here.
//
//   TlsSettings   what a config or a client option names: files and the minimum version. One
//                 struct for every TLS connection: the hub's listener, and later hub links and
//                 direct paths.
//   TlsContext    the settings loaded (certificate, key, CA files read and checked): create it
//                 once, at start, off the hot path; shared by every session; immutable.
//   TlsSession    one connection's TLS state. Not thread-safe: one thread at a time.
#pragma once

#include <skrobot/runtime/result.h>

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

namespace skr::flow {

struct TlsSettings {
  // PEM certificate chain and its private key. Required for a server; a client sends them when
  // the hub asks for a client certificate.
  std::string cert_file;
  std::string key_file;
  // PEM CA certificates. Server: when set, every client must present a certificate signed by one
  // of them. Client: the CAs that may sign the hub's certificate (empty: the system's store).
  std::string ca_file;
  std::string min_version = "1.2";  // "1.2" or "1.3"

  [[nodiscard]] bool hasCertificate() const noexcept { return !cert_file.empty(); }
};

enum class TlsRole { server, client };

class TlsContext {
 public:
  // Reads and checks the files now (blocking disk I/O: call at start). Errc::config_error naming
  // the file and OpenSSL's reason: a missing or unreadable file, a key that does not match the
  // certificate, a bad min_version; a server without cert_file or key_file.
  [[nodiscard]] static Result<TlsContext> create(TlsRole role, const TlsSettings& settings);

  [[nodiscard]] TlsRole role() const noexcept;
  // Server: whether clients must present a certificate.
  [[nodiscard]] bool requiresPeerCertificate() const noexcept;

  struct Impl;
  [[nodiscard]] const std::shared_ptr<Impl>& impl() const noexcept { return impl_; }

 private:
  explicit TlsContext(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<Impl> impl_;
};

class TlsSession {
 public:
  // A session on `context`. Client role: `host` is the name (or numeric address) the hub's
  // certificate must carry, sent as SNI when it is a name; it starts the handshake (output() has
  // the ClientHello). Errc::internal when OpenSSL cannot allocate.
  [[nodiscard]] static Result<TlsSession> open(const TlsContext& context,
                                               std::string_view host = {});
  ~TlsSession();
  TlsSession(TlsSession&&) noexcept;
  TlsSession& operator=(TlsSession&&) noexcept;
  TlsSession(const TlsSession&) = delete;
  TlsSession& operator=(const TlsSession&) = delete;

  // Bytes received from the peer. Advances the handshake; application data becomes readable with
  // read(). Errc::protocol_error with a readable reason when the handshake or a record fails
  // ("certificate verify failed: certificate has expired", "peer did not return a certificate",
  // ...); output() may then hold an alert for the peer: send it, then close the socket.
  [[nodiscard]] Result<void> receive(std::string_view cipher);
  // Decrypted bytes into buf; 0 when nothing more is readable now. Errc::closed once the peer
  // sent close_notify, Errc::protocol_error on a bad record.
  [[nodiscard]] Result<size_t> read(char* buf, size_t capacity);
  // Queues application data: encrypted into output() now, or once the handshake is done.
  [[nodiscard]] Result<void> write(std::string_view plain);
  // Appends what must be sent to the peer (handshake, records, alerts) to `out` and forgets it.
  void takeOutput(std::string& out);
  [[nodiscard]] bool hasOutput() const noexcept;
  [[nodiscard]] bool established() const noexcept;
  // Queues close_notify (send output() before closing the socket).
  void shutdown() noexcept;
  // "TLSv1.3 TLS_AES_256_GCM_SHA384, peer CN=..." for log lines, once established.
  [[nodiscard]] std::string describe() const;
  // The subject of the certificate the peer sent ("/CN=robot"), empty when it sent none.
  [[nodiscard]] std::string peerSubject() const;

 private:
  struct Impl;
  explicit TlsSession(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

// Whether the first bytes a peer sent look like a TLS ClientHello (a handshake record, 0x16, of
// version 3.x). Read as a FlowProtocol frame length that would be more than 64 KiB, which no
// LOGIN comes near. `bytes` shorter than 3: decided on what is there.
[[nodiscard]] bool looksLikeTls(std::string_view bytes) noexcept;

}  // namespace skr::flow
