// SPDX-License-Identifier: Apache-2.0
// Transports: how the bytes of one FlowProtocol connection travel, on either side (the hub's
// Connection, the satellite library's Link). One small interface, one implementation per kind:
// Unix socket, TCP, TLS as a layer over TCP (skrobot/runtime/flow/tls.h), WebSocket as a layer
// over TCP or TLS. Addresses are parsed
// by skrobot/runtime/flow/address.h; their grammar is docs/flow-protocol.md's "Addresses".
//
//   Transport   one connection's pipe: reading into a receiver, pause/resume, gathered writes,
//               close with a reason, who the peer is, the frame limit, descriptors.
//   Listener    listens on an address; each accepted connection is handed over as a Transport.
//   Dialer      opens a Transport to an address (resolving off the loop thread, connecting, the
//               TLS handshake), or says why it could not.
//
// Namespace skr::flow::transport (skr::flow::Transport is what the accounts' rules call a
// connection's origin, accounts.h).
//
// Thread: a transport, listener or dialer lives on the loop it was made on; every call and every
// callback is on that loop's thread. Callbacks never come from inside a call (start, write,
// close...), always from the loop itself.
//
// The shapes of the kinds beyond a byte stream:
// - Message-based transports (UDP datagrams, serial sessions; message_session.h): framing() is
//   `messages`; the receiver gets message() with one whole frame per message (length prefix
//   included, never split or joined), and writes are given whole frames that the transport
//   sends one per message (tryWrite takes whole frames only). maxFrameBytes() is the largest
//   message. The test transport of tests/flow/transport_test.cpp is one, and the hub's
//   Connection runs over it.
// - WebSocket (ws_transport.h, a layer over TCP or TLS): framing() is `frame_messages`. Reads
//   are a stream (the payload of binary messages, unmasked into the receiver's buffer; a message
//   that ends inside a frame is refused), so the receiver's frame limit is the only one; each
//   write call is one binary message of whole frames.
// - One multiplexed line (a serial port carrying one session at a time): each session is a
//   Transport of its own over the line; close() of a session transport ends that session (the
//   line says so to the other end) and closed() follows, while the device stays open and the
//   line's listener hands the next session over as a new Transport. The device is the
//   listener's to open and close, never a session's.
// - A logged-in connection handed to another thread: pause(), let the write under way finish
//   (written()), then the transport gives up its loop (`detach()`, returning what it holds: the
//   descriptor, the peer's identity, a TLS session) and `adopt()` makes a transport of the same
//   kind on the other loop; no byte is lost because the receiver's buffer goes with the
//   connection, and a TLS session with what it decrypted. Unix sockets, TCP and TLS do it;
//   WebSocket's framing and message sessions do not travel.
// - Descriptor access: descriptor() is the plain socket for zero-copy system calls (sendfile,
//   splice, MSG_ZEROCOPY) and socket options; -1 where bytes are transformed (TLS) or there is no
//   descriptor (memory, a multiplexed session).
#pragma once

#include <skrobot/runtime/flow/address.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/result.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace skr {
class Loop;
}

namespace skr::flow::transport {

enum class TransportKind : uint8_t { unix_socket, tcp, tls, memory, serial, udp, websocket };
// "unix", "tcp", "tls", "memory", "serial", "udp", "ws": log lines, statistics.
[[nodiscard]] std::string_view transportKindName(TransportKind kind) noexcept;

// Who is at the other end: what the login throttle counts by and what permission rules read.
struct PeerIdentity {
  TransportKind kind = TransportKind::unix_socket;
  int64_t uid = -1;           // Unix socket: the peer process's uid (SO_PEERCRED); -1 unknown
  std::string address{};      // TCP, TLS: the peer's numeric address; UDP: "ip:port"; empty when
                              // unknown
  std::string certificate{};  // TLS: the subject of the certificate the peer sent; empty if none
  std::string device{};       // serial: the device the line is on
  std::string account{};      // serial: the account the port is bound to (it logs in without a
                              // password); empty: the board logs in with its own credentials.
                              // UDP: the account whose key opened the session
  std::string origin{};       // WebSocket: the upgrade request's Origin header; empty if none
                              // (a page sends it; Node.js, flowctl and curl do not)

  // "uid:<n>" for a Unix peer, "tcp:<address>" for TCP and TLS ("unix:?", "tcp:?" unknown),
  // "serial:<device>" for a board on a serial line, "udp:<ip>:<port>" for a UDP session,
  // "ws:<address>" for WebSocket (over TCP or TLS).
  [[nodiscard]] std::string source() const;
};

// Why a transport can carry nothing more, as its receiver hears it.
struct TransportEnd {
  enum class Why : uint8_t {
    peer_closed,  // the peer closed (EOF, TLS close_notify)
    error,        // the system said no (a read or write failed)
    refused,      // the peer spoke the wrong language: TLS on a plain port, plain on a TLS port, a
                  // failed handshake or a bad record (the transport told the peer, if it could)
  };
  Why why = Why::error;
  std::string message;
};

// What a transport gives up to move its connection to another loop (Transport::detach, then
// adopt there): the socket and who is at the other end, and a TLS connection's session. It owns
// the descriptor: closed when dropped, unless adopted.
class Detached {
 public:
  Detached(TransportKind kind, int fd, PeerIdentity peer) noexcept
      : kind_(kind), fd_(fd), peer_(std::move(peer)) {}
  // A TLS connection: its session (established) goes with the socket, holding what it read and
  // did not deliver yet; `server`: the accepting side's.
  Detached(int fd, PeerIdentity peer, TlsSession session, bool server) noexcept
      : kind_(TransportKind::tls),
        fd_(fd),
        peer_(std::move(peer)),
        tls_(std::move(session)),
        tls_server_(server) {}
  ~Detached();
  Detached(Detached&& other) noexcept;
  Detached& operator=(Detached&& other) noexcept;
  Detached(const Detached&) = delete;
  Detached& operator=(const Detached&) = delete;

  [[nodiscard]] TransportKind kind() const noexcept { return kind_; }
  [[nodiscard]] int descriptor() const noexcept { return fd_; }
  [[nodiscard]] const PeerIdentity& peer() const noexcept { return peer_; }
  // The descriptor, no longer closed by this object.
  [[nodiscard]] int release() noexcept;
  // TLS: the session (adopt() takes it) and its side.
  [[nodiscard]] std::optional<TlsSession>& tlsSession() noexcept { return tls_; }
  [[nodiscard]] bool tlsServer() const noexcept { return tls_server_; }

 private:
  TransportKind kind_;
  int fd_;
  PeerIdentity peer_;
  std::optional<TlsSession> tls_;
  bool tls_server_ = false;
};

class Transport {
 public:
  enum class Framing : uint8_t {
    stream,    // bytes: received() in pieces of any size, frames split by the receiver
    messages,  // one whole frame per message(); writes are whole frames
    // Read as a stream (received()), written as messages: each write call is one message and
    // must hold whole frames, one or more (WebSocket: the peer may hand out views of a message's
    // frames without reassembling them). Output never cuts a frame across two calls here.
    frame_messages,
  };

  // What a transport delivers to. Implemented by the connection that owns the transport.
  class Receiver {
   public:
    // Stream framing: where the next bytes go (at least one byte of room). The transport writes
    // up to its size, then calls received() with how many it wrote there.
    virtual std::span<char> readBuffer() = 0;
    virtual void received(size_t n) = 0;
    // Message framing: one whole message, valid during the call only.
    virtual void message(std::string_view bytes) = 0;
    // The write() under way finished: everything was written, or it failed (then ended() does
    // not follow for it: close the transport).
    virtual void written(Result<void> result) = 0;
    // The transport can carry nothing more. The receiver closes it (close()).
    virtual void ended(const TransportEnd& end) = 0;
    // close() has finished; the receiver may destroy the transport here.
    virtual void closed() noexcept = 0;

   protected:
    Receiver() = default;
    ~Receiver() = default;
    Receiver(const Receiver&) = default;
    Receiver& operator=(const Receiver&) = default;
    Receiver(Receiver&&) = default;
    Receiver& operator=(Receiver&&) = default;
  };

  Transport() = default;
  virtual ~Transport() = default;  // destroying one closes it at once; no callback follows
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;
  Transport(Transport&&) = delete;
  Transport& operator=(Transport&&) = delete;

  [[nodiscard]] virtual TransportKind kind() const noexcept = 0;
  [[nodiscard]] virtual Framing framing() const noexcept { return Framing::stream; }

  // Starts delivering to `receiver` (which must outlive the transport or its close). Errc::io_error
  // when the transport cannot read.
  [[nodiscard]] virtual Result<void> start(Receiver& receiver) = 0;
  // Reads nothing more from the peer until resume(); bytes already taken in (a TLS record
  // decrypted with others) may still be delivered. Idempotent.
  virtual void pause() noexcept = 0;
  [[nodiscard]] virtual Result<void> resume() = 0;

  // A gathered write: the buffers in order, one system call where the transport has them.
  // tryWrite writes what the transport takes now, never waiting: the byte count (0: nothing now,
  // or a write() is under way), Errc::io_error when the connection broke. write() writes all of
  // them, the buffers' bytes staying valid and unchanged until written(); one at a time.
  [[nodiscard]] virtual Result<size_t> tryWrite(std::span<const std::string_view> buffers) = 0;
  [[nodiscard]] virtual Result<void> write(std::span<const std::string_view> buffers) = 0;

  // Stops reading and writing (a write under way is dropped) and lets go of the system's
  // resources; closed() follows from the loop. `reason` is for whatever the transport tells the
  // other end (a TLS close_notify is sent when it can be). Idempotent.
  virtual void close(std::string_view reason) noexcept = 0;

  [[nodiscard]] virtual PeerIdentity peer() const = 0;
  // The largest frame this transport carries (a datagram's size); streams impose none.
  [[nodiscard]] virtual uint32_t maxFrameBytes() const noexcept {
    return std::numeric_limits<uint32_t>::max();
  }
  // Whether descriptors can travel with the bytes (Unix sockets: physical mode).
  [[nodiscard]] virtual bool passesDescriptors() const noexcept { return false; }
  // The plain socket underneath for zero-copy system calls and socket options; -1 otherwise.
  [[nodiscard]] virtual int descriptor() const noexcept { return -1; }

  // Gives up the connection, to be adopted on another loop (adopt()): paused first, with no
  // write() under way (Errc::invalid_argument otherwise), it closes here without a callback and
  // nothing it read is lost (the bytes the receiver took stay with the receiver). Unix sockets,
  // TCP and TLS (established, with no record waiting to be sent); Errc::unsupported for the
  // other kinds (WebSocket and message sessions keep state of their own that does not travel).
  [[nodiscard]] virtual Result<Detached> detach() {
    return makeError(Errc::unsupported, std::string(transportKindName(kind())) +
                                            " connections cannot move to another loop yet");
  }
};

// The connection `detached` gave up, as a transport of `loop` (start() it there).
[[nodiscard]] Result<std::unique_ptr<Transport>> adopt(Loop& loop, Detached detached);

// What listening on an address needs beyond the address.
struct ListenOptions {
  // tls: addresses: every accepted connection is a TLS session on this context.
  std::optional<TlsContext> tls;
  // tls: what a peer that speaks plain on the TLS port is sent, as it is, before it is refused.
  std::string plain_peer_reply;
  int backlog = 128;
  unsigned socket_mode = 0660;  // local: the socket file's permissions
};

class Listener {
 public:
  using Accepted = std::function<void(std::unique_ptr<Transport>)>;

  // Listens on `address` (local:, tcp:, tls:; a tcp port 0 takes a free one). A WebSocket
  // server listens on tcp: or tls:, reads each request head and upgrades the connection
  // (runtime/internal/http_head.h: http::upgrade); ws: and wss: are no listener's addresses. A
  // local: socket file left by a process that is gone is replaced; one that a live process answers
  // on is Errc::already_exists. Errc::io_error naming the address when the system refuses,
  // Errc::invalid_argument for an address it cannot listen on.
  [[nodiscard]] static Result<std::unique_ptr<Listener>> open(Loop& loop, const Address& address,
                                                              ListenOptions options,
                                                              Accepted accepted);
  Listener() = default;
  virtual ~Listener() = default;  // stops listening; a local: listener removes its socket file
  Listener(const Listener&) = delete;
  Listener& operator=(const Listener&) = delete;
  Listener(Listener&&) = delete;
  Listener& operator=(Listener&&) = delete;

  // The TCP port listened on (the one taken when 0 was asked); 0 for a local: listener.
  [[nodiscard]] virtual uint16_t port() const noexcept = 0;
};

// The 16 bytes of an account's UDP key (`skrobot user key NAME`; flow/udp.h parses its hex).
using UdpKey = std::array<uint8_t, 16>;

// What dialling an address needs beyond the address.
struct DialOptions {
  // tls: the client's context (required there: its error is the dialer's).
  const Result<TlsContext>* tls = nullptr;
  // udp: the account whose key opens the session (its LOGIN must name the same) and that key.
  std::string udp_user;
  std::optional<UdpKey> udp_key;
  // udp: how long the handshake may take (HELLO, then OPEN, each sent again every 200 ms); the
  // largest datagram sent (the hub's server.udp.max_datagram: a larger frame is not sent); and how
  // long an open session may hear nothing from the hub before it ends.
  uint32_t udp_handshake_ms = 5000;
  uint32_t udp_max_datagram = 1200;
  uint32_t udp_silence_ms = 10000;
};

class Dialer {
 public:
  using Opened = std::function<void(Result<std::unique_ptr<Transport>>)>;

  // Opens a transport to `address`: a name is resolved on libuv's thread pool, then connected;
  // a tls: address then does its handshake with `tls` (required there: its error is the
  // dialer's). `opened` is called once, from the loop, with the transport (not started) or the
  // reason ("connect: connection refused", "TLS with tls:host:9000: certificate verify
  // failed..."). Destroying the dialer first cancels it: `opened` is not called.
  // A udp: address sends the handshake to the resolved address (the next one when the system
  // says the port is closed) and hands over the session once the hub accepts it: "no answer to
  // the UDP handshake..." when it does not within options.udp_handshake_ms, naming the likely
  // cause (no key, a key that is not the account's, no server.udp there).
  // A ws: or wss: address connects (wss: with its TLS handshake, `tls` required), sends the
  // WebSocket upgrade for its path offering the subprotocol skrobot-flow.v1, and hands over the
  // transport (TransportKind::websocket) once the server's 101 names it with the right
  // Sec-WebSocket-Accept: "WebSocket upgrade with ws:host:8080/flow: the server answered 404...".
  [[nodiscard]] static std::unique_ptr<Dialer> open(Loop& loop, const Address& address,
                                                    const DialOptions& options, Opened opened);
  [[nodiscard]] static std::unique_ptr<Dialer> open(Loop& loop, const Address& address,
                                                    const Result<TlsContext>* tls, Opened opened) {
    DialOptions options;
    options.tls = tls;
    return open(loop, address, options, std::move(opened));
  }
  Dialer() = default;
  virtual ~Dialer() = default;
  Dialer(const Dialer&) = delete;
  Dialer& operator=(const Dialer&) = delete;
  Dialer(Dialer&&) = delete;
  Dialer& operator=(Dialer&&) = delete;
};

}  // namespace skr::flow::transport
