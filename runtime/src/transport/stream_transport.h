// SPDX-License-Identifier: Apache-2.0
// Unix sockets and TCP: a libuv stream as a Transport. Internal to the runtime (listener.cpp,
// dialer.cpp make them). The libuv handle lives on the heap until libuv's close callback, so the
// transport may be destroyed at any time, even with a write or a connect under way.
#pragma once

#include <skrobot/runtime/flow/transport.h>

#include <uv.h>

#include <functional>
#include <string>

namespace skr::flow::transport {

class StreamTransport final : public Transport {
 public:
  // A handle of `kind` (unix_socket or tcp) on `loop`, not connected yet: accept into stream(),
  // or connect().
  StreamTransport(Loop& loop, TransportKind kind);
  ~StreamTransport() override;

  [[nodiscard]] uv_stream_t* stream() noexcept;
  // A plain TCP port: the first bytes are checked for a TLS ClientHello, which is refused.
  void refuseTlsPeers() noexcept { check_tls_ = true; }
  // Connects to `addr` (TCP) or `path` (Unix); `done` gets libuv's status, from the loop, unless
  // the transport is destroyed first.
  void connect(const sockaddr* addr, std::function<void(int status)> done);
  void connect(const std::string& path, std::function<void(int status)> done);

  [[nodiscard]] TransportKind kind() const noexcept override { return kind_; }
  [[nodiscard]] Result<void> start(Receiver& receiver) override;
  void pause() noexcept override;
  [[nodiscard]] Result<void> resume() override;
  [[nodiscard]] Result<size_t> tryWrite(std::span<const std::string_view> buffers) override;
  [[nodiscard]] Result<void> write(std::span<const std::string_view> buffers) override;
  void close(std::string_view reason) noexcept override;
  [[nodiscard]] PeerIdentity peer() const override;
  [[nodiscard]] bool passesDescriptors() const noexcept override {
    return kind_ == TransportKind::unix_socket;
  }
  [[nodiscard]] int descriptor() const noexcept override;
  [[nodiscard]] Result<Detached> detach() override;
  // Takes `fd` (a connected socket of this transport's kind) as its own.
  [[nodiscard]] Result<void> open(int fd);

 private:
  struct Handle;
  static void onAlloc(uv_handle_t* h, size_t suggested, uv_buf_t* buf);
  static void onRead(uv_stream_t* s, ssize_t nread, const uv_buf_t* buf);

  Handle* h_;  // null once libuv closed it
  TransportKind kind_;
  Receiver* rx_ = nullptr;
  bool reading_ = false;
  bool writing_ = false;  // a write() under way
  bool closing_ = false;
  bool ended_ = false;
  bool check_tls_ = false;
};

}  // namespace skr::flow::transport
