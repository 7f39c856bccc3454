// SPDX-License-Identifier: Apache-2.0
// One libuv stream to a hub (internal to the satellite library): connects, splits incoming bytes
// into frames, and writes everything queued during one loop iteration in one write.
//
// A tls: address gets a TLS session (skrobot/runtime/flow/tls.h) on the TCP stream: onLinkConnected comes
// once the handshake is done, frames are split from the decrypted bytes, and queued output is
// encrypted as a whole at flush time.
//
// Loop thread only. A Link is heap-allocated by open() and deletes itself once libuv has closed
// its handles: after close() by the owner (no callback follows), or after reporting a failure
// through Handler::onLinkClosed (the owner must forget the pointer there, and not call close()).
#pragma once

#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/satellite/address.h>

#include <uv.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace skr::sat::detail {

// A hub that closes the connection while we write must not kill the process (SIGPIPE's default
// action): the write fails with EPIPE and the satellite reconnects. Sets SIGPIPE to ignored once,
// and only when the process left it at its default. Called by every Link.
void ignoreSigpipe();

class Link {
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

  // Starts connecting; failures come later through onLinkClosed. `tls` is required for a tls:
  // address (its failure is reported as the link's) and ignored otherwise.
  [[nodiscard]] static Link* open(uv_loop_t* loop, const Address& address,
                                  const Result<flow::TlsContext>* tls, uint32_t max_frame_bytes,
                                  Handler& handler);
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
  enum class State { resolving, connecting, handshaking, open, failed, closed };
  Link(uv_loop_t* loop, const Address& address, const Result<flow::TlsContext>* tls,
       uint32_t max_frame_bytes, Handler& handler);
  ~Link() = default;

  [[nodiscard]] uv_stream_t* stream() noexcept { return reinterpret_cast<uv_stream_t*>(&h_); }
  void start();
  void connectTcp(const sockaddr* addr);
  void fail(std::string why, bool protocol = false);
  void release();  // one outstanding handle or request finished; delete when none is left
  void closeHandles() noexcept;
  void flush();
  void processInput();
  void receiveTls(const char* data, size_t n);
  void kick();  // flush at the end of this loop iteration

  static void onResolved(uv_getaddrinfo_t* req, int status, addrinfo* res);
  static void onConnect(uv_connect_t* req, int status);
  static void onAlloc(uv_handle_t* h, size_t suggested, uv_buf_t* buf);
  static void onRead(uv_stream_t* s, ssize_t nread, const uv_buf_t* buf);
  static void onWrite(uv_write_t* req, int status);
  static void onIdle(uv_idle_t* idle);
  static void onClosed(uv_handle_t* h);

  uv_loop_t* loop_;
  Address address_;
  std::optional<Result<flow::TlsContext>> tls_context_;  // tls: addresses
  std::optional<flow::TlsSession> tls_;
  std::unique_ptr<char[]> tls_in_;  // ciphertext as read
  flow::FrameSplitter splitter_;
  Handler& handler_;
  State state_ = State::connecting;
  union {
    uv_pipe_t pipe;
    uv_tcp_t tcp;
  } h_{};
  uv_idle_t idle_{};
  uv_connect_t connect_req_{};
  uv_write_t write_req_{};
  uv_getaddrinfo_t resolve_req_{};
  int outstanding_ = 0;  // handles not closed yet + resolve in flight
  bool handles_closing_ = false;
  bool idle_active_ = false;
  bool writing_ = false;
  std::string failure_;
  bool failure_protocol_ = false;

  std::string out_;       // queued, not yet handed to libuv
  std::string inflight_;  // being written
  uint64_t writes_ = 0;

  std::unique_ptr<char[]> rbuf_;
  size_t rcap_ = 0, rstart_ = 0, rend_ = 0, rneed_ = 0;
};

}  // namespace skr::sat::detail
