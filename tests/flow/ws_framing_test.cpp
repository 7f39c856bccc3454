// SPDX-License-Identifier: Apache-2.0
// FlowProtocol over WebSocket (runtime/src/transport/ws_transport.h, ws_frame.h, http_head.h):
// the frame reader on its own (fragments, control frames between fragments, 7/16/64-bit lengths,
// the refusals and their close codes, a message that ends inside a FlowProtocol frame), the
// HTTP head parser and the handshake's key, and a server end over a real socket, spoken to in
// raw bytes (refusals on the wire, the close handshake, ping/pong, writes under backpressure) and
// by the ws: dialer; and the hub's Connection over it (login, publish and subscribe, a frame over
// the limit refused before allocation).
#include "http_head.h"
#include "server_impl.h"
#include "temp_dir.h"
#include "ws_frame.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop.h>

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <functional>

namespace skr::test {
namespace {

using namespace flow::transport;  // NOLINT(google-build-using-namespace)
using flow::Address;
namespace ws = flow::ws;
namespace http = flow::http;
namespace msg = flow::msg;

constexpr Nanos kWait = 5 * kNsPerSec;
constexpr ws::MaskKey kMask{0x11, 0x22, 0x33, 0x44};

// A FlowProtocol frame: the 4-byte little-endian length, the code, the body.
std::string flowFrame(uint8_t code, std::string_view body) {
  std::string f(4, '\0');
  const auto len = static_cast<uint32_t>(body.size() + 1);
  std::memcpy(f.data(), &len, 4);
  f.push_back(static_cast<char>(code));
  f.append(body);
  return f;
}

// A frame as a client sends it (masked) or a server (`mask` null).
std::string wsFrame(ws::Opcode op, bool fin, std::string_view payload,
                    const ws::MaskKey* mask = &kMask, uint8_t extra_bits = 0) {
  std::string f(ws::kMaxHeaderBytes, '\0');
  f.resize(ws::writeHeader(f.data(), op, fin, payload.size(), mask));
  f[0] = static_cast<char>(f[0] | extra_bits);
  const size_t at = f.size();
  f.append(payload);
  if (mask != nullptr) ws::applyMask(f.data() + at, payload.size(), *mask, 0);
  return f;
}

// What a reader delivered.
struct ReadSink final : ws::FrameReader::Sink {
  std::string data;
  std::vector<std::pair<ws::Opcode, std::string>> controls;
  char buf[7];  // small: payloads cross many room() calls
  std::span<char> room() override { return {buf, sizeof buf}; }
  bool payload(size_t n) override {
    data.append(buf, n);
    return true;
  }
  bool control(ws::Opcode op, std::string_view p) override {
    controls.emplace_back(op, std::string(p));
    return true;
  }
};

// Feeds `bytes` one byte at a time (every header and payload split everywhere) and whole.
void feedBoth(bool server, const std::string& bytes,
              const std::function<void(ws::FrameReader&, ReadSink&)>& check) {
  {
    ws::FrameReader r(server);
    ReadSink s;
    for (size_t i = 0; i < bytes.size() && !r.failure(); ++i) r.feed(bytes.substr(i, 1), s);
    check(r, s);
  }
  ws::FrameReader r(server);
  ReadSink s;
  r.feed(bytes, s);
  check(r, s);
}

// The word-at-a-time mask against the RFC's byte rule, at every offset into the key, across the
// 8-byte steps and the tail.
TEST(WsFrame, MaskingMatchesTheByteRuleAtEveryOffsetAndLength) {
  for (uint64_t offset = 0; offset < 8; ++offset) {
    for (size_t n = 0; n <= 41; ++n) {
      std::string data(n, '\0');
      for (size_t i = 0; i < n; ++i) data[i] = static_cast<char>(i * 37 + offset);
      std::string want = data;
      for (size_t i = 0; i < n; ++i) want[i] = static_cast<char>(want[i] ^ kMask[(offset + i) & 3]);
      ws::applyMask(data.data(), n, kMask, offset);
      ASSERT_EQ(data, want) << "offset " << offset << ", " << n << " bytes";
    }
  }
}

TEST(WsFrameReader, ReadsFragmentsWithControlFramesBetweenThem) {
  const std::string a = flowFrame(0x20, "first");
  const std::string b = flowFrame(0x21, std::string(300, 'b'));  // 16-bit length below
  const std::string payload = a + b;
  const std::string wire = wsFrame(ws::Opcode::binary, false, payload.substr(0, 3)) +
                           wsFrame(ws::Opcode::ping, true, "p1") +
                           wsFrame(ws::Opcode::continuation, false, payload.substr(3, 200)) +
                           wsFrame(ws::Opcode::pong, true, "") +
                           wsFrame(ws::Opcode::continuation, true, payload.substr(203));
  feedBoth(true, wire, [&](ws::FrameReader& r, ReadSink& s) {
    ASSERT_FALSE(r.failure()) << r.failure()->why;
    EXPECT_EQ(s.data, payload);
    ASSERT_EQ(s.controls.size(), 2u);
    EXPECT_EQ(s.controls[0].first, ws::Opcode::ping);
    EXPECT_EQ(s.controls[0].second, "p1");
    EXPECT_EQ(s.controls[1].first, ws::Opcode::pong);
    EXPECT_TRUE(r.atMessageBoundary());
  });
}

TEST(WsFrameReader, ReadsSevenSixteenAndSixtyFourBitLengths) {
  for (const size_t body : {size_t{100}, size_t{125}, size_t{126}, size_t{65535}, size_t{70000}}) {
    const std::string f = flowFrame(0x20, std::string(body - 5, 'x'));
    const std::string wire = wsFrame(ws::Opcode::binary, true, f);
    const size_t header = body < 126 ? 6 : body <= 0xFFFF ? 8 : 14;
    EXPECT_EQ(wire.size(), header + body) << body;
    ws::FrameReader r(true);
    ReadSink s;
    EXPECT_EQ(r.feed(wire, s), wire.size());
    ASSERT_FALSE(r.failure()) << body << ": " << r.failure()->why;
    EXPECT_EQ(s.data, f) << body;
  }
  // A client reads a server's unmasked frames.
  const std::string f = flowFrame(0x20, "x");
  feedBoth(false, wsFrame(ws::Opcode::binary, true, f, nullptr),
           [&](ws::FrameReader& r, ReadSink& s) {
             ASSERT_FALSE(r.failure()) << r.failure()->why;
             EXPECT_EQ(s.data, f);
           });
}

TEST(WsFrameReader, RefusesWhatBreaksTheRulesWithTheRightCloseCode) {
  const std::string f = flowFrame(0x20, "x");
  const struct {
    const char* what;
    bool server;
    std::string wire;
    uint16_t code;
  } cases[] = {
      {"text", true, wsFrame(ws::Opcode::text, true, "hello"), ws::kCloseUnsupportedData},
      {"RSV1", true, wsFrame(ws::Opcode::binary, true, f, &kMask, 0x40), ws::kCloseProtocolError},
      {"RSV3", true, wsFrame(ws::Opcode::binary, true, f, &kMask, 0x10), ws::kCloseProtocolError},
      {"unmasked from a client", true, wsFrame(ws::Opcode::binary, true, f, nullptr),
       ws::kCloseProtocolError},
      {"masked from a server", false, wsFrame(ws::Opcode::binary, true, f),
       ws::kCloseProtocolError},
      {"opcode 3", true, wsFrame(static_cast<ws::Opcode>(3), true, f), ws::kCloseProtocolError},
      {"opcode 11", true, wsFrame(static_cast<ws::Opcode>(11), true, ""), ws::kCloseProtocolError},
      {"lone continuation", true, wsFrame(ws::Opcode::continuation, true, f),
       ws::kCloseProtocolError},
      {"binary inside a message", true,
       wsFrame(ws::Opcode::binary, false, "") + wsFrame(ws::Opcode::binary, true, f),
       ws::kCloseProtocolError},
      {"fragmented ping", true, wsFrame(ws::Opcode::ping, false, ""), ws::kCloseProtocolError},
      {"ping of 126 bytes", true, wsFrame(ws::Opcode::ping, true, std::string(126, 'p')),
       ws::kCloseProtocolError},
      {"message ends inside a frame", true, wsFrame(ws::Opcode::binary, true, f.substr(0, 5)),
       ws::kCloseInvalidPayload},
      {"message ends inside a length", true, wsFrame(ws::Opcode::binary, true, f + f.substr(0, 2)),
       ws::kCloseInvalidPayload},
  };
  for (const auto& c : cases) {
    feedBoth(c.server, c.wire, [&](ws::FrameReader& r, ReadSink&) {
      ASSERT_TRUE(r.failure()) << c.what;
      EXPECT_EQ(r.failure()->code, c.code) << c.what << ": " << r.failure()->why;
    });
  }
  ws::FrameReader r(true);
  ReadSink s;
  r.feed(wsFrame(ws::Opcode::binary, true, f.substr(0, 5)), s);
  EXPECT_EQ(r.failure()->why, "a WebSocket message ended inside a frame");
}

// Messages mode (a module's subprotocol): text and binary messages, fragmented or not, each
// ended with its first opcode; one byte over the limit is refused on its header (1009).
struct MessageSink final : ws::FrameReader::Sink {
  std::string current;
  std::vector<std::pair<ws::Opcode, std::string>> messages;
  std::vector<ws::Opcode> controls;
  char buf[3];
  std::span<char> room() override { return {buf, sizeof buf}; }
  bool payload(size_t n) override {
    current.append(buf, n);
    return true;
  }
  bool control(ws::Opcode op, std::string_view) override {
    controls.push_back(op);
    return true;
  }
  bool messageEnd(ws::Opcode op) override {
    messages.emplace_back(op, std::move(current));
    current.clear();
    return true;
  }
};

TEST(WsFrameReader, MessagesModeReadsTextAndBinaryMessagesUpToItsLimit) {
  const std::string wire =
      wsFrame(ws::Opcode::text, true, R"({"type":"hello"})") +
      wsFrame(ws::Opcode::binary, false, "ab") + wsFrame(ws::Opcode::ping, true, "p") +
      wsFrame(ws::Opcode::continuation, true, "cd") + wsFrame(ws::Opcode::text, true, "") +
      wsFrame(ws::Opcode::binary, true, std::string(16, 'z'));
  for (const bool bytewise : {false, true}) {
    auto r = ws::FrameReader::messages(true, 16);
    MessageSink s;
    if (bytewise) {
      for (size_t i = 0; i < wire.size() && !r.failure(); ++i) r.feed(wire.substr(i, 1), s);
    } else {
      EXPECT_EQ(r.feed(wire, s), wire.size());
    }
    ASSERT_FALSE(r.failure()) << r.failure()->why;
    ASSERT_EQ(s.messages.size(), 4u);
    EXPECT_EQ(s.messages[0], std::make_pair(ws::Opcode::text, std::string(R"({"type":"hello"})")));
    EXPECT_EQ(s.messages[1], std::make_pair(ws::Opcode::binary, std::string("abcd")));
    EXPECT_EQ(s.messages[2], std::make_pair(ws::Opcode::text, std::string()));
    EXPECT_EQ(s.messages[3].second, std::string(16, 'z'));
    EXPECT_EQ(s.controls, std::vector<ws::Opcode>{ws::Opcode::ping});
    EXPECT_TRUE(r.atMessageBoundary());
  }
  // 17 bytes, in one frame or as 10 + 7: refused on the header that goes over, none of its
  // payload read.
  for (const std::string& over :
       {wsFrame(ws::Opcode::binary, true, std::string(17, 'x')),
        wsFrame(ws::Opcode::text, false, std::string(10, 'x')) +
            wsFrame(ws::Opcode::continuation, true, std::string(7, 'x'))}) {
    auto r = ws::FrameReader::messages(true, 16);
    MessageSink s;
    r.feed(over, s);
    ASSERT_TRUE(r.failure());
    EXPECT_EQ(r.failure()->code, ws::kCloseMessageTooBig);
    EXPECT_TRUE(s.messages.empty());
    EXPECT_LE(s.current.size(), 10u);
  }
  // A 2^62-byte announcement allocates nothing.
  std::string huge = wsFrame(ws::Opcode::binary, true, "");
  huge[1] = static_cast<char>(0x80 | 127);
  huge.insert(2, std::string("\x40\0\0\0\0\0\0\0", 8));
  auto r = ws::FrameReader::messages(true, 1 << 20);
  MessageSink s;
  r.feed(huge, s);
  ASSERT_TRUE(r.failure());
  EXPECT_EQ(r.failure()->code, ws::kCloseMessageTooBig);
  // The FlowProtocol reader still refuses text.
  ws::FrameReader flow(true);
  MessageSink t;
  flow.feed(wsFrame(ws::Opcode::text, true, "x"), t);
  ASSERT_TRUE(flow.failure());
  EXPECT_EQ(flow.failure()->code, ws::kCloseUnsupportedData);
}

TEST(WsFrameReader, AHugeLengthAllocatesNothingAndPassesTheFlowLengthOn) {
  // 2^40 payload bytes announced: the reader buffers none of it; the receiver sees the
  // FlowProtocol length (and refuses it before allocating, as on any stream).
  std::string wire(ws::kMaxHeaderBytes, '\0');
  wire.resize(ws::writeHeader(wire.data(), ws::Opcode::binary, true, uint64_t{1} << 40, &kMask));
  std::string flow_len("\x00\xFF\xFF\x7F", 4);
  ws::applyMask(flow_len.data(), 4, kMask, 0);
  wire += flow_len;
  ws::FrameReader r(true);
  ReadSink s;
  EXPECT_EQ(r.feed(wire, s), wire.size());
  EXPECT_FALSE(r.failure());
  EXPECT_EQ(s.data, std::string("\x00\xFF\xFF\x7F", 4));
  // The top bit of a 64-bit length is refused.
  std::string top = wsFrame(ws::Opcode::binary, true, std::string(70000, 'x'));
  top[2] = static_cast<char>(0x80);
  ws::FrameReader t(true);
  t.feed(top, s);
  ASSERT_TRUE(t.failure());
  EXPECT_EQ(t.failure()->code, ws::kCloseProtocolError);
}

TEST(HttpHead, ParsesAnUpgradeRequestAndComputesTheAccept) {
  const std::string head =
      "GET /flow?x=1 HTTP/1.1\r\nHost: robot.local:8080\r\nupgrade: WebSocket\r\n"
      "Connection: keep-alive, Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
      "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: chat\r\n"
      "sec-websocket-protocol: skrobot-flow.v1 , other\r\nOrigin: http://robot.local:8080\r\n\r\n";
  ASSERT_EQ(http::headEnd(head + "tail"), head.size());
  EXPECT_EQ(http::headEnd(head.substr(0, head.size() - 1)), 0u);
  auto r = http::parseRequest(head);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->method, "GET");
  EXPECT_EQ(r->path(), "/flow");
  EXPECT_EQ(r->header("host"), "robot.local:8080");
  EXPECT_EQ(r->header("origin"), "http://robot.local:8080");
  EXPECT_EQ(r->list("sec-websocket-protocol"),
            (std::vector<std::string>{"chat", "skrobot-flow.v1", "other"}));
  EXPECT_FALSE(http::checkWebSocket(*r));
  // RFC 6455 section 1.3's example.
  EXPECT_EQ(http::websocketAccept("dGhlIHNhbXBsZSBub25jZQ=="), "s3pPLMBiTxaQ9kYGzzhZRbK+xOo=");
}

TEST(HttpHead, RefusesMalformedHeadsWithAReason) {
  const char* bad[] = {
      "GET /flow HTTP/1.1\r\nHost x\r\n\r\n",       // no colon
      "GET flow HTTP/1.1\r\n\r\n",                  // not an absolute path
      "GET /flow HTTP/2\r\n\r\n",                   // version
      "DELETE /flow HTTP/1.1\r\n\r\n",              // method
      "GET /flow HTTP/1.1\r\n folded: x\r\n\r\n",   // folding
      "GET  /flow HTTP/1.1\r\n\r\n",                // two spaces
      "GET /flow HTTP/1.1\r\nA: b\x01\r\n\r\n",     // control character
      "GET /flow HTTP/1.1\r\nBad Name: b\r\n\r\n",  // a blank in a name
  };
  for (const char* b : bad) {
    auto r = http::parseRequest(b);
    EXPECT_FALSE(r) << b;
    if (!r) {
      EXPECT_FALSE(r.error().message.empty());
    }
  }
  EXPECT_FALSE(http::parseRequest("GET / HTTP/1.1\r\n" + std::string(9000, 'a') + ": b\r\n\r\n"));
  auto no_key = http::parseRequest(
      "GET /flow HTTP/1.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: short\r\n\r\n");
  ASSERT_TRUE(no_key);
  EXPECT_EQ(http::checkWebSocket(*no_key), "Sec-WebSocket-Key is not 16 bytes in base64");
  EXPECT_TRUE(http::errorResponse(403, "no").starts_with("HTTP/1.1 403 Forbidden\r\n"));
}

// A receiver that keeps what it is told.
struct Sink final : Transport::Receiver {
  std::string bytes;
  std::optional<TransportEnd> end;
  int writes = 0;
  bool closed_ = false;
  std::function<void()> on_bytes;
  char buf[65536];

  std::span<char> readBuffer() override { return {buf, sizeof buf}; }
  void received(size_t n) override {
    bytes.append(buf, n);
    if (on_bytes) on_bytes();
  }
  void message(std::string_view) override {}
  void written(Result<void> r) override {
    ++writes;
    EXPECT_TRUE(r.ok());
  }
  void ended(const TransportEnd& e) override { end = e; }
  void closed() noexcept override { closed_ = true; }
};

// Reads an HTTP request head from an accepted connection, then upgrades it (the hub's web
// port's job, W2: here the smallest one).
struct Upgrader final : Transport::Receiver {
  Loop& loop;
  std::unique_ptr<Transport> t;
  std::string head;
  std::function<void(Result<std::unique_ptr<Transport>>)> done;
  char buf[4096];

  Upgrader(Loop& l, std::unique_ptr<Transport> transport) : loop(l), t(std::move(transport)) {}
  std::span<char> readBuffer() override { return {buf, sizeof buf}; }
  void received(size_t n) override {
    head.append(buf, n);
    const size_t end = http::headEnd(head);
    if (end == 0) return;
    t->pause();
    auto request = http::parseRequest(std::string_view(head).substr(0, end));
    ASSERT_TRUE(request) << request.error().message;
    done(http::upgrade(loop, std::move(t), *request, http::kFlowSubprotocol,
                       std::string_view(head).substr(end)));
  }
  void message(std::string_view) override {}
  void written(Result<void>) override {}
  void ended(const TransportEnd&) override {}
  void closed() noexcept override {}
};

constexpr std::string_view kUpgrade =
    "GET /flow HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
    "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
    "Sec-WebSocket-Protocol: skrobot-flow.v1\r\nOrigin: http://127.0.0.1\r\n\r\n";

class WsPair : public ::testing::Test {
 protected:
  // A TCP listener whose connections are upgraded to WebSocket server ends, started with
  // server_sink_.
  void listen(Address at = Address{.kind = Address::Kind::tcp, .host = "127.0.0.1", .port = 0},
              ListenOptions options = {}) {
    auto l = Listener::open(loop_, at, std::move(options), [this](std::unique_ptr<Transport> t) {
      upgrader_ = std::make_unique<Upgrader>(loop_, std::move(t));
      upgrader_->done = [this](Result<std::unique_ptr<Transport>> r) {
        ASSERT_TRUE(r) << r.error().message;
        server_ = std::move(r).value();
        ASSERT_TRUE(server_->start(server_sink_));
      };
      ASSERT_TRUE(upgrader_->t->start(*upgrader_));
    });
    ASSERT_TRUE(l) << l.error().message;
    listener_ = std::move(l).value();
  }
  std::unique_ptr<Transport> dial(const std::string& address,
                                  const Result<flow::TlsContext>* tls = nullptr) {
    std::optional<Result<std::unique_ptr<Transport>>> opened;
    auto parsed = Address::parse(address);
    EXPECT_TRUE(parsed);
    auto d = Dialer::open(loop_, *parsed, tls, [&](Result<std::unique_ptr<Transport>> r) {
      opened.emplace(std::move(r));
    });
    EXPECT_TRUE(loop_.runUntil([&] { return opened.has_value(); }, kWait));
    EXPECT_TRUE(*opened) << opened->error().message;
    return *opened ? std::move(opened->value()) : nullptr;
  }
  // A plain TCP client that has sent the upgrade request and read the 101.
  void rawClient() {
    listen();
    raw_ = dial("tcp:127.0.0.1:" + std::to_string(listener_->port()));
    ASSERT_TRUE(raw_);
    ASSERT_TRUE(raw_->start(raw_sink_));
    const std::string_view req = kUpgrade;
    ASSERT_TRUE(raw_->write({&req, 1}));
    ASSERT_TRUE(loop_.runUntil([&] { return http::headEnd(raw_sink_.bytes) > 0; }, kWait));
    const size_t end = http::headEnd(raw_sink_.bytes);
    EXPECT_TRUE(raw_sink_.bytes.starts_with("HTTP/1.1 101 Switching Protocols\r\n"));
    EXPECT_NE(raw_sink_.bytes.find("Sec-WebSocket-Accept: s3pPLMBiTxaQ9kYGzzhZRbK+xOo=\r\n"),
              std::string::npos);
    EXPECT_NE(raw_sink_.bytes.find("Sec-WebSocket-Protocol: skrobot-flow.v1\r\n"),
              std::string::npos);
    raw_sink_.bytes.erase(0, end);
    ASSERT_TRUE(loop_.runUntil([&] { return server_ != nullptr; }, kWait));
  }
  void rawSend(const std::string& bytes) {
    const std::string_view b = bytes;
    auto n = raw_->tryWrite({&b, 1});
    ASSERT_TRUE(n);
    ASSERT_EQ(*n, bytes.size());
  }
  // The close frame the server sent: its code.
  uint16_t closeCodeSeen() {
    EXPECT_TRUE(loop_.runUntil([&] { return raw_sink_.bytes.size() >= 4; }, kWait));
    if (raw_sink_.bytes.size() < 4) return 0;
    EXPECT_EQ(static_cast<uint8_t>(raw_sink_.bytes[0]), 0x88) << "FIN + close";
    return static_cast<uint16_t>(static_cast<uint8_t>(raw_sink_.bytes[2]) << 8 |
                                 static_cast<uint8_t>(raw_sink_.bytes[3]));
  }

  Loop loop_;
  std::unique_ptr<Listener> listener_;
  std::unique_ptr<Upgrader> upgrader_;
  std::unique_ptr<Transport> server_, raw_;
  Sink server_sink_, raw_sink_;
};

TEST_F(WsPair, TheServerEndReadsMaskedFragmentsAndAnswersPingsAtAMessageBoundary) {
  rawClient();
  EXPECT_EQ(server_->kind(), TransportKind::websocket);
  EXPECT_EQ(server_->framing(), Transport::Framing::frame_messages);
  EXPECT_EQ(transportKindName(server_->kind()), "ws");
  EXPECT_EQ(server_->peer().origin, "http://127.0.0.1");
  EXPECT_TRUE(server_->peer().source().starts_with("ws:127.0.0.1")) << server_->peer().source();
  const std::string f = flowFrame(0x20, "hello");
  rawSend(wsFrame(ws::Opcode::binary, false, f.substr(0, 4)) +
          wsFrame(ws::Opcode::ping, true, "are you there") +
          wsFrame(ws::Opcode::continuation, true, f.substr(4)));
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.bytes.size() >= f.size(); }, kWait));
  EXPECT_EQ(server_sink_.bytes, f);
  ASSERT_TRUE(loop_.runUntil([&] { return raw_sink_.bytes.size() >= 15; }, kWait));
  EXPECT_EQ(raw_sink_.bytes, wsFrame(ws::Opcode::pong, true, "are you there", nullptr));
  // Each write call is one unmasked binary message.
  raw_sink_.bytes.clear();
  const std::string g = flowFrame(0x21, "a") + flowFrame(0x22, "bc");
  const std::string_view parts[] = {std::string_view(g).substr(0, 3),
                                    std::string_view(g).substr(3)};
  auto n = server_->tryWrite(parts);
  ASSERT_TRUE(n);
  EXPECT_EQ(*n, g.size());
  ASSERT_TRUE(loop_.runUntil([&] { return raw_sink_.bytes.size() >= g.size() + 2; }, kWait));
  EXPECT_EQ(raw_sink_.bytes, wsFrame(ws::Opcode::binary, true, g, nullptr));
}

TEST_F(WsPair, RefusalsSendTheirCloseCodeAndEndTheTransport) {
  const struct {
    const char* what;
    std::string wire;
    uint16_t code;
  } cases[] = {
      {"text", wsFrame(ws::Opcode::text, true, "{}"), ws::kCloseUnsupportedData},
      {"RSV", wsFrame(ws::Opcode::binary, true, flowFrame(0x20, ""), &kMask, 0x20),
       ws::kCloseProtocolError},
      {"unmasked", wsFrame(ws::Opcode::binary, true, flowFrame(0x20, ""), nullptr),
       ws::kCloseProtocolError},
      {"inside a frame", wsFrame(ws::Opcode::binary, true, flowFrame(0x20, "abc").substr(0, 6)),
       ws::kCloseInvalidPayload},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    server_.reset();
    raw_.reset();
    server_sink_ = {};
    raw_sink_ = {};
    rawClient();
    rawSend(c.wire);
    EXPECT_EQ(closeCodeSeen(), c.code);
    ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.end.has_value(); }, kWait));
    EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::error);
    EXPECT_TRUE(server_sink_.end->message.starts_with("WebSocket: ")) << server_sink_.end->message;
    EXPECT_LT(server_sink_.bytes.size(), 8u) << "a refused message's frame never arrives whole";
  }
}

TEST_F(WsPair, ACloseIsEchoedAndEndsTheTransport) {
  rawClient();
  rawSend(wsFrame(ws::Opcode::close, true, ws::closePayload(ws::kCloseGoingAway, "page left")));
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.end.has_value(); }, kWait));
  EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::peer_closed);
  EXPECT_EQ(server_sink_.end->message, "the peer closed the WebSocket (1001 page left)");
  EXPECT_EQ(closeCodeSeen(), ws::kCloseGoingAway) << "the echo";
  // Our own close sends a close frame first (1000).
  raw_sink_ = {};
  server_.reset();
  rawClient();
  server_->close("bye");
  EXPECT_EQ(closeCodeSeen(), ws::kCloseNormal);
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.closed_; }, kWait));
}

TEST_F(WsPair, WritesUnderBackpressureKeepWholeMessagesInOrder) {
  rawClient();
  raw_->pause();  // the client reads nothing: the socket fills up
  const std::string big = flowFrame(0x20, std::string(1 << 20, 'q'));
  std::string expected;
  int zero = 0, messages = 0;
  for (int i = 0; i < 64 && zero == 0; ++i) {
    const std::string_view b = big;
    auto n = server_->tryWrite({&b, 1});
    ASSERT_TRUE(n);
    if (*n == 0) {
      ++zero;  // what the socket did not take waits: no second message interleaves
    } else {
      EXPECT_EQ(*n, big.size()) << "a message is taken whole or not at all";
      expected += wsFrame(ws::Opcode::binary, true, big, nullptr);
      ++messages;
    }
  }
  EXPECT_EQ(zero, 1) << "the socket never filled up";
  // write() waits behind what is left, then reports written().
  const std::string small = flowFrame(0x21, "after");
  const std::string_view s = small;
  ASSERT_TRUE(server_->write({&s, 1}));
  expected += wsFrame(ws::Opcode::binary, true, small, nullptr);
  ASSERT_TRUE(raw_->resume());
  ASSERT_TRUE(loop_.runUntil([&] { return raw_sink_.bytes.size() >= expected.size(); }, kWait));
  EXPECT_TRUE(raw_sink_.bytes == expected)
      << messages << " messages, " << raw_sink_.bytes.size() << " bytes of " << expected.size();
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.writes == 1; }, kWait));
}

TEST_F(WsPair, TheWsDialerUpgradesAndBothEndsCarryFramesBothWays) {
  listen();
  auto client = dial("ws:127.0.0.1:" + std::to_string(listener_->port()) + "/flow");
  ASSERT_TRUE(client);
  EXPECT_EQ(client->kind(), TransportKind::websocket);
  Sink client_sink;
  ASSERT_TRUE(client->start(client_sink));
  ASSERT_TRUE(loop_.runUntil([&] { return server_ != nullptr; }, kWait));
  EXPECT_EQ(server_->peer().origin, "") << "a ws: client sends no Origin";
  const std::string up = flowFrame(0x20, "up") + flowFrame(0x21, std::string(100000, 'u'));
  const std::string_view u = up;
  ASSERT_TRUE(client->write({&u, 1}));  // masked by the client, unmasked by the server
  const std::string down = flowFrame(0x22, "down");
  const std::string_view d = down;
  ASSERT_TRUE(server_->tryWrite({&d, 1}));
  ASSERT_TRUE(loop_.runUntil(
      [&] {
        return server_sink_.bytes.size() >= up.size() && client_sink.bytes.size() >= down.size();
      },
      kWait));
  EXPECT_TRUE(server_sink_.bytes == up);
  EXPECT_EQ(client_sink.bytes, down);
  client->close("done");
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.end.has_value(); }, kWait));
  EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::peer_closed);
  EXPECT_EQ(server_sink_.end->message, "the peer closed the WebSocket (1000 done)");
}

TEST_F(WsPair, WssIsWebSocketOverTheHubsTls) {
  TempDir dir("ws-tls-test");
  const auto certs = dir.path() / "certs";
  const std::string cmd = std::string("sh ") + SKROBOT_SOURCE_DIR +
                          "/tests/support/make_test_certs.sh " + certs.string() +
                          " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  flow::TlsSettings server;
  server.cert_file = (certs / "hub.pem").string();
  server.key_file = (certs / "hub.key").string();
  auto server_ctx = flow::TlsContext::create(flow::TlsRole::server, server);
  ASSERT_TRUE(server_ctx) << server_ctx.error().message;
  ListenOptions options;
  options.tls = std::move(server_ctx).value();
  listen(Address{.kind = Address::Kind::tls, .host = "127.0.0.1", .port = 0}, std::move(options));
  flow::TlsSettings client;
  client.ca_file = (certs / "ca.pem").string();
  const auto client_ctx = flow::TlsContext::create(flow::TlsRole::client, client);
  auto c = dial("wss:localhost:" + std::to_string(listener_->port()) + "/flow", &client_ctx);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->kind(), TransportKind::websocket);
  Sink client_sink;
  ASSERT_TRUE(c->start(client_sink));
  ASSERT_TRUE(loop_.runUntil([&] { return server_ != nullptr; }, kWait));
  const std::string up = flowFrame(0x20, std::string(70000, 's'));
  const std::string_view u = up;
  ASSERT_TRUE(c->write({&u, 1}));
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.bytes.size() >= up.size(); }, kWait));
  EXPECT_TRUE(server_sink_.bytes == up);
}

TEST_F(WsPair, TheWsDialerRefusesAServerThatDoesNotUpgrade) {
  // A plain TCP listener that answers 404.
  auto l =
      Listener::open(loop_, Address{.kind = Address::Kind::tcp, .host = "127.0.0.1", .port = 0}, {},
                     [this](std::unique_ptr<Transport> t) {
                       raw_ = std::move(t);
                       raw_sink_.on_bytes = [this] {
                         if (http::headEnd(raw_sink_.bytes) == 0) return;
                         const std::string a = http::errorResponse(404, "no flows here");
                         const std::string_view v = a;
                         (void)raw_->tryWrite({&v, 1});
                       };
                       ASSERT_TRUE(raw_->start(raw_sink_));
                     });
  ASSERT_TRUE(l);
  std::optional<Result<std::unique_ptr<Transport>>> opened;
  auto d = Dialer::open(loop_, *Address::parse("ws:127.0.0.1:" + std::to_string((*l)->port())),
                        nullptr, [&](auto r) { opened.emplace(std::move(r)); });
  ASSERT_TRUE(loop_.runUntil([&] { return opened.has_value(); }, kWait));
  ASSERT_FALSE(*opened);
  EXPECT_NE(opened->error().message.find("answered 404 Not Found instead of 101"),
            std::string::npos)
      << opened->error().message;
  EXPECT_NE(raw_sink_.bytes.find("Sec-WebSocket-Protocol: skrobot-flow.v1\r\n"), std::string::npos);
}

// A ws: client of an in-process hub: frames encoded here, replies split from its stream.
struct WsClient {
  Loop& loop;
  std::unique_ptr<Transport> t{};
  Sink sink{};
  size_t taken = 0;

  template <class M>
  void send(const M& m) {
    std::string f;
    ASSERT_TRUE(flow::encode(f, m));
    put(f);
  }
  void sendCode(flow::Code code) {
    std::string f;
    flow::appendHeader(f, code, 0);
    put(f);
  }
  // tryWrite takes nothing while a message is still leaving: again after a turn of the loop.
  void put(const std::string& f) {
    const std::string_view v = f;
    for (int i = 0; i < 5000; ++i) {
      auto n = t->tryWrite({&v, 1});
      ASSERT_TRUE(n) << n.error().message;
      if (*n == f.size()) return;
      ASSERT_EQ(*n, 0u);
      loop.runFor(kNsPerMs);
    }
    FAIL() << "the transport took nothing for 5 s";
  }
  // The next frame of `code` (others skipped), its body; nullopt after kWait.
  std::optional<std::string> next(flow::Code code) {
    const flow::FrameSplitter split(1 << 24);
    std::optional<std::string> body;
    loop.runUntil(
        [&] {
          while (!body) {
            const auto n = split.next(reinterpret_cast<const uint8_t*>(sink.bytes.data()) + taken,
                                      sink.bytes.size() - taken);
            if (n.status != flow::FrameSplitter::Status::frame) return false;
            taken += n.consumed;
            if (n.code == static_cast<uint8_t>(code)) body = std::string(n.body);
          }
          return true;
        },
        kWait);
    return body;
  }
};

TEST_F(WsPair, TheHubsConnectionRunsOverWebSocket) {
  TempDir dir("ws-hub-test");
  auto users = flow::UsersFile::load(dir.path() / "users.json");
  ASSERT_TRUE(users);
  ASSERT_TRUE(users->add("alice", "s3cret-pass"));
  ASSERT_TRUE(users->save());
  flow::ServerOptions o;
  o.app_name = "skrobot-ws-" + std::to_string(::getpid());
  o.unix_path = (dir.path() / "hub.sock").string();
  o.data_dir = dir.path() / "data";
  o.users_file = dir.path() / "users.json";
  auto hub = std::make_unique<flow::FlowServer::Impl>(loop_, o);
  ASSERT_TRUE(hub->start());
  // The upgraded connections go to the hub (as its web port will hand them over).
  auto l =
      Listener::open(loop_, Address{.kind = Address::Kind::tcp, .host = "127.0.0.1", .port = 0}, {},
                     [&](std::unique_ptr<Transport> t) {
                       auto* up = new Upgrader(loop_, std::move(t));
                       up->done = [&, up](Result<std::unique_ptr<Transport>> r) {
                         ASSERT_TRUE(r) << r.error().message;
                         hub->accept(std::move(r).value());
                         loop_.post([up] { delete up; });
                       };
                       ASSERT_TRUE(up->t->start(*up));
                     });
  ASSERT_TRUE(l);
  const std::string at = "ws:127.0.0.1:" + std::to_string((*l)->port()) + "/flow";
  const auto open = [&](WsClient& c) {
    c.t = dial(at);
    ASSERT_TRUE(c.t);
    ASSERT_TRUE(c.t->start(c.sink));
    msg::Login m;
    m.user = "alice";
    m.password = "s3cret-pass";
    c.send(m);
    ASSERT_TRUE(c.next(flow::Code::reply_ok));
    c.sendCode(flow::Code::go_async);
    ASSERT_TRUE(c.next(flow::Code::reply_ok));
  };
  WsClient pub{loop_}, sub{loop_};
  open(pub);
  open(sub);
  msg::ChanAdd add;
  add.tag = 5;
  add.kind = static_cast<uint8_t>(flow::ChannelKind::streaming);
  add.short_name = "camera";
  add.mime = "application/octet-stream";
  add.props = flow::Variant(flow::Variant::Map{});
  pub.send(add);
  auto added = pub.next(flow::Code::ev_chan_added);
  ASSERT_TRUE(added);
  auto ev = flow::decode<msg::EvChanAdded>(*added);
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->info.name, "alice.camera");
  sub.send(msg::Subscribe{1, ev->info.id});
  ASSERT_TRUE(pub.next(flow::Code::ev_start_publish));
  const std::string big(300000, 'p');  // larger than the hub's write slice: one message still
  pub.send(msg::Publish{ev->info.id, {"small"}});
  pub.send(msg::Publish{ev->info.id, {big}});
  for (const std::string& want : {std::string("small"), big}) {
    auto body = sub.next(flow::Code::ev_data);
    ASSERT_TRUE(body);
    auto data = flow::decode<msg::EvData>(*body);
    ASSERT_TRUE(data);
    EXPECT_TRUE(data->payload.bytes == want) << data->payload.bytes.size();
  }

  // A subscriber that reads nothing for a while: the hub's output goes in slices, and over
  // WebSocket no slice cuts a frame (the client refuses a message that ends inside one, 1007).
  sub.t->pause();
  for (int i = 0; i < 64; ++i) pub.send(msg::Publish{ev->info.id, {big}});
  pub.send(msg::Publish{ev->info.id, {"last"}});
  loop_.runFor(100 * kNsPerMs);
  ASSERT_TRUE(sub.t->resume());
  for (bool last = false; !last;) {
    auto data = sub.next(flow::Code::ev_data);
    ASSERT_TRUE(data) << (sub.sink.end ? sub.sink.end->message : "no EV_DATA");
    last = flow::decode<msg::EvData>(*data)->payload.bytes == "last";
  }
  EXPECT_FALSE(sub.sink.end);

  // A frame length over the limit (4096 before login) in a message that announces 2^40 bytes:
  // that connection alone closes, nothing allocated.
  WsClient bad{loop_};
  bad.t = dial(at);
  ASSERT_TRUE(bad.t);
  ASSERT_TRUE(bad.t->start(bad.sink));
  const std::string huge("\xF0\xFF\xFF\x7F\x01", 5);
  const std::string_view h = huge;
  ASSERT_TRUE(bad.t->tryWrite({&h, 1}));
  ASSERT_TRUE(loop_.runUntil([&] { return bad.sink.end.has_value(); }, kWait));
  EXPECT_EQ(hub->stats.protocol_errors, 1u);
  pub.send(msg::Publish{ev->info.id, {"still here"}});
  auto body = sub.next(flow::Code::ev_data);
  ASSERT_TRUE(body);
  EXPECT_EQ(flow::decode<msg::EvData>(*body)->payload.bytes, "still here");
  pub.t.reset();
  sub.t.reset();
  bad.t.reset();
  hub->stop();
  hub.reset();
  loop_.runFor(10 * kNsPerMs);
}

}  // namespace
}  // namespace skr::test
