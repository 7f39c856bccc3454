// SPDX-License-Identifier: Apache-2.0
// A blocking FlowProtocol client for tests and benchmarks: one socket, explicit frames.
#pragma once

#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/result.h>

#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

struct skr_udp;

namespace skr::test {

struct Frame {
  uint8_t code = 0;
  std::string body;
  [[nodiscard]] flow::Code kind() const { return static_cast<flow::Code>(code); }
};

class TestClient {
 public:
  TestClient() = default;
  ~TestClient();
  TestClient(const TestClient&) = delete;
  TestClient& operator=(const TestClient&) = delete;
  TestClient(TestClient&& o) noexcept;
  TestClient& operator=(TestClient&& o) noexcept;

  [[nodiscard]] static Result<TestClient> connectUnix(const std::string& path);
  [[nodiscard]] static Result<TestClient> connectTcp(const std::string& host, uint16_t port);
  // A board's end of a serial line (a pseudo-terminal's master, raw): frames travel in the line
  // framing of satellite/mcu/src/skr_line.h. Takes the descriptor.
  [[nodiscard]] static TestClient overLine(int fd);
  // Bytes written to the line as they are (noise, a frame cut short), bypassing the framing.
  bool sendLineBytes(std::string_view bytes);
  // A board's UDP session (satellite/mcu/posix/skr_udp.h) with the hub at host:port as `user`
  // with its key: one frame per datagram. The handshake is done here (io_error when it fails).
  [[nodiscard]] static Result<TestClient> overUdp(const std::string& host, uint16_t port,
                                                  const std::string& user,
                                                  const std::array<uint8_t, 16>& key);
  // The UDP session's state (its sequence numbers, its counters); null for other clients.
  [[nodiscard]] skr_udp* udp() const noexcept;

  // LOGIN and wait for the reply.
  // `minor`: the protocol minor the client announces (an older client's).
  [[nodiscard]] Result<flow::msg::LoginOk> login(
      const std::string& user, const std::string& password,
      flow::ValueEncoding enc = flow::ValueEncoding::binary, uint16_t minor = flow::kProtocolMinor);
  // LOGIN then GO_ASYNC.
  [[nodiscard]] Result<flow::msg::LoginOk> loginFlow(const std::string& user,
                                                     const std::string& password);

  template <class M>
  bool send(const M& m, flow::ValueEncoding enc = flow::ValueEncoding::binary) {
    std::string out;
    if (!flow::encode(out, m, enc)) return false;
    return sendRaw(out);
  }
  bool sendRaw(std::string_view bytes);

  // The next frame (from the queue of frames skipped by waitFor, then the socket).
  [[nodiscard]] std::optional<Frame> recv(int timeout_ms = 5000);
  // The next frame with `code`; other frames are kept for later recv() calls.
  [[nodiscard]] std::optional<Frame> waitFor(flow::Code code, int timeout_ms = 5000);
  // A sync request and its reply frame (REPLY_OK or REPLY_ERROR).
  template <class M>
  std::optional<Frame> call(const M& m, flow::ValueEncoding enc = flow::ValueEncoding::binary) {
    if (!send(m, enc)) return std::nullopt;
    return recvReply();
  }
  std::optional<Frame> recvReply(int timeout_ms = 5000);

  // True once the hub closed the connection (reads EOF within the timeout).
  [[nodiscard]] bool closedByPeer(int timeout_ms = 5000);
  [[nodiscard]] int fd() const noexcept { return fd_; }
  void close();

 private:
  explicit TestClient(int fd) : fd_(fd) {}
  struct Line;
  std::optional<Frame> readFrame(int timeout_ms);
  bool fill(int timeout_ms);

  int fd_ = -1;
  std::string buf_;
  std::deque<Frame> skipped_;
  std::shared_ptr<Line> line_;    // set for a serial line
  std::shared_ptr<skr_udp> udp_;  // set for a UDP session
};

// A decoded message that owns the frame its payload views point into.
template <class M>
struct Decoded : M {
  std::shared_ptr<const Frame> frame;
};

// Decodes a frame body as M (gtest-friendly: nullopt on mismatch).
template <class M>
std::optional<Decoded<M>> as(const std::optional<Frame>& f) {
  if (!f || f->code != static_cast<uint8_t>(M::code)) return std::nullopt;
  auto owned = std::make_shared<const Frame>(*f);
  auto r = flow::decode<M>(owned->body);
  if (!r) return std::nullopt;
  Decoded<M> d{std::move(r).value(), nullptr};
  d.frame = std::move(owned);
  return d;
}

}  // namespace skr::test
