// SPDX-License-Identifier: Apache-2.0
// TLS through memory BIOs (skrobot/runtime/flow/tls.h). OpenSSL never touches a socket here:
// received bytes go into the read BIO, what OpenSSL wants to send accumulates in the write BIO.
#include <skrobot/runtime/flow/tls.h>

#include <arpa/inet.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>

#include <climits>
#include <cstring>

namespace skr::flow {
namespace {

// OpenSSL's error queue as one line, emptied; `fallback` when it is empty.
std::string takeErrors(const std::string& fallback) {
  std::string out;
  while (const unsigned long e = ERR_get_error()) {
    char buf[256];
    ERR_error_string_n(e, buf, sizeof buf);
    // "error:0A000086:SSL routines::certificate verify failed": keep the reason.
    std::string_view text(buf);
    if (const size_t colon = text.rfind(':'); colon != std::string_view::npos) {
      text.remove_prefix(colon + 1);
    }
    if (!out.empty()) out += "; ";
    out += text;
  }
  return out.empty() ? fallback : out;
}

Error configError(const std::string& what, const std::string& file) {
  return makeError(Errc::config_error,
                   "TLS: " + what + " " + file + ": " + takeErrors("cannot be read"));
}

bool isNumericHost(std::string_view host) {
  const std::string h(host);
  unsigned char buf[sizeof(in6_addr)];
  return inet_pton(AF_INET, h.c_str(), buf) == 1 || inet_pton(AF_INET6, h.c_str(), buf) == 1;
}

}  // namespace

bool looksLikeTls(std::string_view bytes) noexcept {
  if (bytes.empty()) return false;
  if (static_cast<unsigned char>(bytes[0]) != 0x16) return false;
  if (bytes.size() >= 2 && bytes[1] != 0x03) return false;
  return bytes.size() < 3 || static_cast<unsigned char>(bytes[2]) <= 0x04;
}

// --- TlsContext ------------------------------------------------------------------------------

struct TlsContext::Impl {
  SSL_CTX* ctx = nullptr;
  TlsRole role = TlsRole::server;
  bool peer_cert_required = false;
  ~Impl() { SSL_CTX_free(ctx); }
};

Result<TlsContext> TlsContext::create(TlsRole role, const TlsSettings& s) {
  ERR_clear_error();
  int min = 0;
  if (s.min_version == "1.2") {
    min = TLS1_2_VERSION;
  } else if (s.min_version == "1.3") {
    min = TLS1_3_VERSION;
  } else {
    return makeError(Errc::config_error,
                     "TLS: min_version must be \"1.2\" or \"1.3\", not \"" + s.min_version + "\"");
  }
  if (role == TlsRole::server && (s.cert_file.empty() || s.key_file.empty())) {
    return makeError(Errc::config_error, "TLS: a server needs a certificate and a key file");
  }
  if (s.cert_file.empty() != s.key_file.empty()) {
    return makeError(Errc::config_error, "TLS: a certificate needs its key file, and the reverse");
  }
  auto impl = std::make_shared<Impl>();
  impl->role = role;
  impl->ctx = SSL_CTX_new(role == TlsRole::server ? TLS_server_method() : TLS_client_method());
  if (impl->ctx == nullptr) return makeError(Errc::internal, "TLS: " + takeErrors("SSL_CTX_new"));
  SSL_CTX* ctx = impl->ctx;
  SSL_CTX_set_min_proto_version(ctx, min);
  SSL_CTX_set_options(ctx, SSL_OP_NO_RENEGOTIATION | SSL_OP_NO_COMPRESSION);
  if (!s.cert_file.empty()) {
    if (SSL_CTX_use_certificate_chain_file(ctx, s.cert_file.c_str()) != 1) {
      return configError("certificate", s.cert_file);
    }
    if (SSL_CTX_use_PrivateKey_file(ctx, s.key_file.c_str(), SSL_FILETYPE_PEM) != 1) {
      return configError("private key", s.key_file);
    }
    if (SSL_CTX_check_private_key(ctx) != 1) {
      return makeError(
          Errc::config_error,
          "TLS: the key " + s.key_file + " does not belong to the certificate " + s.cert_file);
    }
  }
  if (role == TlsRole::server) {
    if (!s.ca_file.empty()) {
      if (SSL_CTX_load_verify_locations(ctx, s.ca_file.c_str(), nullptr) != 1) {
        return configError("client CA file", s.ca_file);
      }
      STACK_OF(X509_NAME)* names = SSL_load_client_CA_file(s.ca_file.c_str());
      if (names == nullptr) return configError("client CA file", s.ca_file);
      SSL_CTX_set_client_CA_list(ctx, names);
      SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER | SSL_VERIFY_FAIL_IF_NO_PEER_CERT, nullptr);
      impl->peer_cert_required = true;
    } else {
      SSL_CTX_set_verify(ctx, SSL_VERIFY_NONE, nullptr);
    }
  } else {
    if (!s.ca_file.empty()) {
      if (SSL_CTX_load_verify_locations(ctx, s.ca_file.c_str(), nullptr) != 1) {
        return configError("CA file", s.ca_file);
      }
    } else if (SSL_CTX_set_default_verify_paths(ctx) != 1) {
      return makeError(Errc::config_error, "TLS: the system's CA store: " + takeErrors("?"));
    }
    SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER, nullptr);
    impl->peer_cert_required = true;
  }
  return TlsContext(std::move(impl));
}

TlsRole TlsContext::role() const noexcept {
  return impl_->role;
}

bool TlsContext::requiresPeerCertificate() const noexcept {
  return impl_->peer_cert_required;
}

// --- TlsSession ------------------------------------------------------------------------------

struct TlsSession::Impl {
  std::shared_ptr<TlsContext::Impl> context;  // keeps the SSL_CTX alive
  SSL* ssl = nullptr;
  BIO* in = nullptr;    // received ciphertext (owned by ssl)
  BIO* out = nullptr;   // ciphertext to send (owned by ssl)
  std::string pending;  // application data written before the handshake finished
  bool failed = false;

  ~Impl() { SSL_free(ssl); }

  // Why the last call failed, in words an operator can act on.
  std::string failure(int rc) const {
    const int err = SSL_get_error(ssl, rc);
    std::string why = takeErrors(err == SSL_ERROR_SYSCALL ? "unexpected end of the stream"
                                                          : "TLS error " + std::to_string(err));
    const long verify = SSL_get_verify_result(ssl);
    if (verify != X509_V_OK) {
      why += ": ";
      why += X509_verify_cert_error_string(verify);
    }
    return why;
  }

  Result<void> handshake() {
    const int rc = SSL_do_handshake(ssl);
    if (rc == 1) return flushPending();
    const int err = SSL_get_error(ssl, rc);
    if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) return {};
    failed = true;
    return makeError(Errc::protocol_error, "TLS handshake failed: " + failure(rc));
  }

  Result<void> writeNow(std::string_view plain) {
    while (!plain.empty()) {
      const int chunk = static_cast<int>(std::min<size_t>(plain.size(), INT_MAX));
      const int rc = SSL_write(ssl, plain.data(), chunk);
      if (rc <= 0) {
        failed = true;
        return makeError(Errc::protocol_error, "TLS write failed: " + failure(rc));
      }
      plain.remove_prefix(static_cast<size_t>(rc));
    }
    return {};
  }

  Result<void> flushPending() {
    if (pending.empty()) return {};
    std::string data;
    data.swap(pending);
    return writeNow(data);
  }
};

TlsSession::TlsSession(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
TlsSession::~TlsSession() = default;
TlsSession::TlsSession(TlsSession&&) noexcept = default;
TlsSession& TlsSession::operator=(TlsSession&&) noexcept = default;

Result<TlsSession> TlsSession::open(const TlsContext& context, std::string_view host) {
  ERR_clear_error();
  auto impl = std::make_unique<Impl>();
  impl->context = context.impl();
  impl->ssl = SSL_new(impl->context->ctx);
  impl->in = BIO_new(BIO_s_mem());
  impl->out = BIO_new(BIO_s_mem());
  if (impl->ssl == nullptr || impl->in == nullptr || impl->out == nullptr) {
    BIO_free(impl->in);
    BIO_free(impl->out);
    return makeError(Errc::internal, "TLS: " + takeErrors("out of memory"));
  }
  // An empty read BIO means "try again", not end of file.
  BIO_set_mem_eof_return(impl->in, -1);
  BIO_set_mem_eof_return(impl->out, -1);
  SSL_set_bio(impl->ssl, impl->in, impl->out);
  if (context.role() == TlsRole::server) {
    SSL_set_accept_state(impl->ssl);
    return TlsSession(std::move(impl));
  }
  SSL_set_connect_state(impl->ssl);
  if (!host.empty()) {
    const std::string h(host);
    if (isNumericHost(h)) {
      X509_VERIFY_PARAM_set1_ip_asc(SSL_get0_param(impl->ssl), h.c_str());
    } else {
      SSL_set_tlsext_host_name(impl->ssl, h.c_str());
      SSL_set1_host(impl->ssl, h.c_str());
    }
  }
  if (auto r = impl->handshake(); !r) return r.error();  // the ClientHello
  return TlsSession(std::move(impl));
}

Result<void> TlsSession::receive(std::string_view cipher) {
  if (impl_->failed) return makeError(Errc::protocol_error, "TLS session failed earlier");
  ERR_clear_error();
  while (!cipher.empty()) {
    const int n = BIO_write(impl_->in, cipher.data(),
                            static_cast<int>(std::min<size_t>(cipher.size(), INT_MAX)));
    if (n <= 0) return makeError(Errc::internal, "TLS: cannot buffer received bytes");
    cipher.remove_prefix(static_cast<size_t>(n));
  }
  if (!SSL_is_init_finished(impl_->ssl)) return impl_->handshake();
  return {};
}

Result<size_t> TlsSession::read(char* buf, size_t capacity) {
  if (impl_->failed) return makeError(Errc::protocol_error, "TLS session failed earlier");
  if (!SSL_is_init_finished(impl_->ssl) || capacity == 0) return size_t{0};
  ERR_clear_error();
  const int rc = SSL_read(impl_->ssl, buf, static_cast<int>(std::min<size_t>(capacity, INT_MAX)));
  if (rc > 0) return static_cast<size_t>(rc);
  const int err = SSL_get_error(impl_->ssl, rc);
  if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) return size_t{0};
  if (err == SSL_ERROR_ZERO_RETURN) return makeError(Errc::closed, "the peer closed TLS");
  impl_->failed = true;
  return makeError(Errc::protocol_error, "TLS read failed: " + impl_->failure(rc));
}

Result<void> TlsSession::write(std::string_view plain) {
  if (impl_->failed) return makeError(Errc::protocol_error, "TLS session failed earlier");
  if (!SSL_is_init_finished(impl_->ssl)) {
    impl_->pending.append(plain);
    return {};
  }
  ERR_clear_error();
  return impl_->writeNow(plain);
}

void TlsSession::takeOutput(std::string& out) {
  const size_t n = BIO_ctrl_pending(impl_->out);
  if (n == 0) return;
  const size_t at = out.size();
  out.resize(at + n);
  const int got =
      BIO_read(impl_->out, out.data() + at, static_cast<int>(std::min<size_t>(n, INT_MAX)));
  out.resize(at + (got > 0 ? static_cast<size_t>(got) : 0));
}

bool TlsSession::hasOutput() const noexcept {
  return BIO_ctrl_pending(impl_->out) > 0;
}

bool TlsSession::established() const noexcept {
  return impl_ != nullptr && !impl_->failed && SSL_is_init_finished(impl_->ssl) != 0;
}

void TlsSession::shutdown() noexcept {
  if (established()) (void)SSL_shutdown(impl_->ssl);
  ERR_clear_error();
}

std::string TlsSession::peerSubject() const {
  std::string subject;
  if (impl_ == nullptr) return subject;  // moved away
  if (X509* peer = SSL_get1_peer_certificate(impl_->ssl)) {
    char name[256] = {};
    X509_NAME_oneline(X509_get_subject_name(peer), name, sizeof name);
    subject = name;
    X509_free(peer);
  }
  return subject;
}

std::string TlsSession::describe() const {
  std::string s = std::string(SSL_get_version(impl_->ssl)) + " " +
                  SSL_CIPHER_get_name(SSL_get_current_cipher(impl_->ssl));
  if (const std::string peer = peerSubject(); !peer.empty()) s += ", peer " + peer;
  return s;
}

}  // namespace skr::flow
