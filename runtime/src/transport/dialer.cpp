// SPDX-License-Identifier: Apache-2.0
// Opening a transport to a hub's address (skrobot/runtime/flow/transport.h): resolving on libuv's
// thread pool, connecting to each resolved address in turn, and for tls: the handshake, for udp:
// the session's handshake (udp_client.h), before the transport is handed over.
#include "stream_transport.h"
#include "tls_transport.h"
#include "udp_client.h"

#include <skrobot/runtime/flow/serial.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/loop_handles.h>

#include <cstring>
#include <optional>
#include <vector>

namespace skr::flow::transport {
namespace {

std::string uvText(const std::string& what, int rc) {
  return what + ": " + uv_strerror(rc);
}

// local:, tcp: and tls: (a stream), and udp: (resolved the same way, then udp_client.h).
class StreamDialer final : public Dialer {
 public:
  StreamDialer(Loop& loop, const Address& address, const DialOptions& options, Opened opened)
      : loop_(loop),
        address_(address),
        options_(options),
        opened_(std::move(opened)),
        report_(loop, [this] { report(); }) {
    options_.tls = nullptr;  // kept in tls_, by value
    if (address.kind == Address::Kind::tls) {
      tls_ = options.tls != nullptr
                 ? *options.tls
                 : Result<TlsContext>(makeError(Errc::invalid_argument, "TLS: no settings"));
    }
  }

  ~StreamDialer() override {
    if (resolve_ != nullptr) resolve_->owner = nullptr;  // its callback frees it
  }
  StreamDialer(const StreamDialer&) = delete;
  StreamDialer& operator=(const StreamDialer&) = delete;
  StreamDialer(StreamDialer&&) = delete;
  StreamDialer& operator=(StreamDialer&&) = delete;

  void start() {
    if (address_.kind == Address::Kind::local) {
      stream_ = std::make_unique<StreamTransport>(loop_, TransportKind::unix_socket);
      stream_->connect(address_.path, [this](int status) { connected(status); });
      return;
    }
    if (tls_ && !*tls_) {
      fail(tls_->error().message);
      return;
    }
    const bool udp = address_.kind == Address::Kind::udp;
    if (udp && !options_.udp_key) {
      fail(address_.toString() + ": a udp: session is opened with the account's key, and none " +
           "was given (ROBOT_UDP_KEY, ROBOT_UDP_KEY_FILE or flowctl's --udp-key-file: the hex " +
           "that `skrobot user key " + options_.udp_user + "` printed)");
      return;
    }
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = udp ? SOCK_DGRAM : SOCK_STREAM;
    const std::string port = std::to_string(address_.port);
    resolve_ = new Resolve;
    resolve_->owner = this;
    resolve_->req.data = resolve_;
    const auto cb = [](uv_getaddrinfo_t* req, int status, addrinfo* res) {
      auto* r = static_cast<Resolve*>(req->data);
      if (r->owner != nullptr) {
        r->owner->resolve_ = nullptr;
        r->owner->resolved(status, res);
      }
      if (res != nullptr) uv_freeaddrinfo(res);
      delete r;
    };
    if (int rc = uv_getaddrinfo(loop_.uv(), &resolve_->req, cb, address_.host.c_str(), port.c_str(),
                                &hints);
        rc < 0) {
      delete resolve_;
      resolve_ = nullptr;
      fail(uvText("resolve " + address_.host, rc));
    }
  }

 private:
  struct Resolve {
    uv_getaddrinfo_t req{};
    StreamDialer* owner = nullptr;
  };

  void resolved(int status, addrinfo* res) {
    if (status < 0 || res == nullptr) {
      fail(uvText("resolve " + address_.host, status));
      return;
    }
    // Every address the name has, tried in the resolver's order ("localhost" may give ::1 first
    // while the hub listens on 127.0.0.1 only).
    for (const addrinfo* a = res; a != nullptr; a = a->ai_next) {
      if (a->ai_addrlen > sizeof(sockaddr_storage)) continue;
      sockaddr_storage s{};
      std::memcpy(&s, a->ai_addr, a->ai_addrlen);
      candidates_.emplace_back(s, a->ai_addrlen);
    }
    if (address_.kind == Address::Kind::udp) {
      handshakeNext();
    } else {
      connectNext();
    }
  }

  // udp: the handshake with each address in turn while the system says its port is closed.
  void handshakeNext() {
    const auto& [to, len] = candidates_[tried_++];
    auto session = UdpClientSession::open(loop_, to, len, options_);
    if (!session) {
      fail(address_.toString() + ": " + session.error().message);
      return;
    }
    udp_ = std::move(session).value();
    udp_->handshake([this](std::optional<TransportEnd> failed) {
      if (!failed) {
        finish(std::unique_ptr<Transport>(std::move(udp_)));
      } else if (failed->why == TransportEnd::Why::refused && tried_ < candidates_.size()) {
        report_.startIn(0);  // the next address, from the loop: udp_ is inside this call
        next_udp_ = true;
      } else {
        fail(address_.toString() + " as \"" + options_.udp_user + "\": " + failed->message);
      }
    });
  }

  void connectNext() {
    const sockaddr_storage next = candidates_[tried_++].first;
    stream_ = std::make_unique<StreamTransport>(loop_, TransportKind::tcp);
    stream_->connect(reinterpret_cast<const sockaddr*>(&next), [this](int st) { connected(st); });
  }

  void connected(int status) {
    if (status < 0 && tried_ < candidates_.size()) {
      connectNext();
      return;
    }
    if (status < 0) {
      fail(uvText("connect", status));
      return;
    }
    if (!tls_) {
      finish(std::unique_ptr<Transport>(std::move(stream_)));
      return;
    }
    auto session = TlsSession::open(**tls_, address_.host);
    if (!session) {
      fail(session.error().message);
      return;
    }
    tls_transport_ = std::make_unique<TlsTransport>(loop_, std::move(stream_),
                                                    std::move(session).value(), false);
    tls_transport_->handshake([this](std::optional<TransportEnd> failed) {
      if (!failed) {
        finish(std::unique_ptr<Transport>(std::move(tls_transport_)));
      } else if (failed->why == TransportEnd::Why::refused) {
        fail("TLS with " + address_.toString() + ": " + failed->message);
      } else if (failed->why == TransportEnd::Why::peer_closed) {
        fail("TLS handshake with " + address_.toString() +
             ": the hub closed the connection (is its TCP port plain? then use a tcp: address)");
      } else {
        fail("read: " + failed->message);
      }
    });
  }

  // Reported from the loop, never from inside open() or a transport's call.
  void fail(std::string why) { finish(makeError(Errc::io_error, std::move(why))); }
  void finish(Result<std::unique_ptr<Transport>> outcome) {
    outcome_.emplace(std::move(outcome));
    report_.startIn(0);
  }
  void report() {
    if (next_udp_) {
      next_udp_ = false;
      udp_.reset();
      handshakeNext();
      return;
    }
    auto outcome = std::move(*outcome_);
    outcome_.reset();
    tls_transport_.reset();
    stream_.reset();
    udp_.reset();
    opened_(std::move(outcome));  // may destroy this
  }

  Loop& loop_;
  Address address_;
  DialOptions options_;
  Opened opened_;
  std::optional<Result<TlsContext>> tls_;
  std::unique_ptr<StreamTransport> stream_;
  std::unique_ptr<TlsTransport> tls_transport_;
  std::unique_ptr<UdpClientSession> udp_;
  bool next_udp_ = false;  // report(): the next address's handshake
  Resolve* resolve_ = nullptr;
  std::vector<std::pair<sockaddr_storage, socklen_t>> candidates_;  // the resolved addresses
  size_t tried_ = 0;
  std::optional<Result<std::unique_ptr<Transport>>> outcome_;
  Timer report_;
};

}  // namespace

// A serial line opens at once; the answer still comes from the loop.
class SerialDialer final : public Dialer {
 public:
  SerialDialer(Loop& loop, const Address& address, Opened opened)
      : result_(openSerialSession(loop, address.path, address.baud)),
        opened_(std::move(opened)),
        report_(loop, [this] { opened_(std::move(result_)); }) {
    report_.startIn(0);
  }

 private:
  Result<std::unique_ptr<Transport>> result_;
  Opened opened_;
  Timer report_;
};

std::unique_ptr<Dialer> Dialer::open(Loop& loop, const Address& address, const DialOptions& options,
                                     Opened opened) {
  if (address.kind == Address::Kind::serial) {
    return std::make_unique<SerialDialer>(loop, address, std::move(opened));
  }
  auto dialer = std::make_unique<StreamDialer>(loop, address, options, std::move(opened));
  dialer->start();
  return dialer;
}

}  // namespace skr::flow::transport
