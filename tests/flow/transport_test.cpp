// SPDX-License-Identifier: Apache-2.0
// The transport layer (skrobot/runtime/flow/transport.h) on its own: Unix, TCP and TLS pairs made
// by a Listener and a Dialer on one loop (gathered writes, pause and resume, how each end hears a
// close or a refusal, peer identity, descriptors), and the hub's Connection over a message-based
// test transport (one frame per message), the proof that the interface carries one.
#include "server_impl.h"
#include "temp_dir.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/transport.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/loop_handles.h>

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace skr::test {
namespace {

using namespace flow::transport;  // NOLINT(google-build-using-namespace)
using flow::Address;
namespace msg = flow::msg;

constexpr Nanos kWait = 5 * kNsPerSec;

// A receiver that keeps what it is told.
struct Sink final : Transport::Receiver {
  std::string bytes;
  std::vector<std::string> messages;
  std::optional<TransportEnd> end;
  int writes = 0;
  bool write_ok = false;
  bool closed_ = false;
  char buf[4096];

  std::span<char> readBuffer() override { return {buf, sizeof buf}; }
  void received(size_t n) override { bytes.append(buf, n); }
  void message(std::string_view m) override { messages.emplace_back(m); }
  void written(Result<void> r) override {
    ++writes;
    write_ok = r.ok();
  }
  void ended(const TransportEnd& e) override { end = e; }
  void closed() noexcept override { closed_ = true; }
};

class TransportPair : public ::testing::Test {
 protected:
  // A listener on `address` and a dialer to it; both ends started with their sinks.
  void connect(Address address, ListenOptions options = {},
               const Result<flow::TlsContext>* client_tls = nullptr) {
    // The listener binds a numeric address; the dialer may name the host (a TLS certificate names
    // "localhost").
    Address listen_at = address;
    if (listen_at.kind != Address::Kind::local) listen_at.host = "127.0.0.1";
    auto l =
        Listener::open(loop_, listen_at, std::move(options), [this](std::unique_ptr<Transport> t) {
          // Started at once, as the hub does: a TLS server end handshakes once it reads.
          server_ = std::move(t);
          ASSERT_TRUE(server_->start(server_sink_));
        });
    ASSERT_TRUE(l) << l.error().message;
    listener_ = std::move(l).value();
    if (address.kind != Address::Kind::local) address.port = listener_->port();
    dial(address, client_tls);
  }
  // A dialer to the listener there; both ends started with their sinks.
  void dial(const Address& address, const Result<flow::TlsContext>* client_tls = nullptr) {
    server_.reset();
    std::optional<Result<std::unique_ptr<Transport>>> opened;
    auto dialer =
        Dialer::open(loop_, address, client_tls,
                     [&](Result<std::unique_ptr<Transport>> r) { opened.emplace(std::move(r)); });
    ASSERT_TRUE(loop_.runUntil([&] { return opened.has_value(); }, kWait));
    ASSERT_TRUE(*opened) << opened->error().message;
    ASSERT_TRUE(loop_.runUntil([&] { return server_ != nullptr; }, kWait));
    client_ = std::move(opened->value());
    ASSERT_TRUE(client_->start(client_sink_));
  }
  // Written by the client with one gathered tryWrite, read by the server.
  void exchange() {
    const std::string_view parts[] = {"gathered ", "in ", "one write"};
    auto n = client_->tryWrite(parts);
    ASSERT_TRUE(n) << n.error().message;
    EXPECT_EQ(*n, 21u);
    ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.bytes.size() >= 21; }, kWait));
    EXPECT_EQ(server_sink_.bytes, "gathered in one write");
  }

  // The server's end moves to another loop mid-stream (detach, then adopt there): what the
  // client wrote meanwhile arrives there, once, and the moved end writes back from there.
  void moveServerMidStream() {
    exchange();  // read on loop_
    server_->pause();
    const std::string_view more = "written during the move";
    ASSERT_TRUE(client_->tryWrite({&more, 1}));
    loop_.runFor(20 * kNsPerMs);
    const std::string_view pending = "!";
    ASSERT_TRUE(server_->write({&pending, 1}));
    auto busy = server_->detach();  // not with a write under way
    ASSERT_FALSE(busy);
    EXPECT_EQ(busy.error().code, Errc::invalid_argument);
    ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.writes == 1; }, kWait));
    const PeerIdentity before = server_->peer();
    auto detached = server_->detach();
    ASSERT_TRUE(detached) << detached.error().message;
    EXPECT_EQ(detached->peer().source(), before.source());
    server_.reset();
    Loop other;
    auto moved = adopt(other, std::move(detached).value());
    ASSERT_TRUE(moved) << moved.error().message;
    Sink there;
    ASSERT_TRUE((*moved)->start(there));
    ASSERT_TRUE(other.runUntil([&] { return there.bytes.size() >= more.size(); }, kWait));
    EXPECT_EQ(there.bytes, more);
    EXPECT_EQ((*moved)->peer().source(), before.source());
    const std::string_view back = "from the other loop";
    ASSERT_TRUE((*moved)->tryWrite({&back, 1}));
    ASSERT_TRUE(
        loop_.runUntil([&] { return client_sink_.bytes.size() >= 1 + back.size(); }, kWait));
    EXPECT_EQ(client_sink_.bytes, "!from the other loop");
    // The old end closed without a word: neither its receiver nor the client heard a close.
    loop_.runFor(20 * kNsPerMs);
    EXPECT_FALSE(server_sink_.closed_);
    EXPECT_FALSE(client_sink_.end);
    // Closed over there, the client hears it.
    (*moved)->close("moved end closes");
    ASSERT_TRUE(other.runUntil([&] { return there.closed_; }, kWait));
    ASSERT_TRUE(loop_.runUntil([&] { return client_sink_.end.has_value(); }, kWait));
    EXPECT_EQ(client_sink_.end->why, TransportEnd::Why::peer_closed);
  }

  TempDir dir_{"transport-test"};
  Loop loop_;
  std::unique_ptr<Listener> listener_;
  std::unique_ptr<Transport> server_, client_;
  Sink server_sink_, client_sink_;
};

TEST_F(TransportPair, UnixSocketCarriesBytesAndNamesItsPeerByUid) {
  connect(Address{.kind = Address::Kind::local, .path = (dir_.path() / "s.sock").string()});
  exchange();
  EXPECT_EQ(server_->kind(), TransportKind::unix_socket);
  EXPECT_EQ(server_->peer().uid, static_cast<int64_t>(::getuid()));
  EXPECT_EQ(server_->peer().source(), "uid:" + std::to_string(::getuid()));
  EXPECT_TRUE(server_->passesDescriptors());
  EXPECT_GE(server_->descriptor(), 0);
  EXPECT_EQ(server_->framing(), Transport::Framing::stream);

  // Paused, the server reads nothing; resumed, it reads what waited.
  server_->pause();
  const std::string_view more = "more";
  ASSERT_TRUE(client_->tryWrite({&more, 1}));
  loop_.runFor(50 * kNsPerMs);
  EXPECT_EQ(server_sink_.bytes.size(), 21u);
  ASSERT_TRUE(server_->resume());
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.bytes.size() == 25; }, kWait));

  // A large gathered write() ends with one written() once the reader took it all.
  const std::string big(size_t{4} << 20, 'x');
  const std::string_view two[] = {big, big};
  ASSERT_TRUE(client_->write(two));
  ASSERT_TRUE(loop_.runUntil(
      [&] { return client_sink_.writes == 1 && server_sink_.bytes.size() == 25 + 2 * big.size(); },
      20 * kNsPerSec));
  EXPECT_TRUE(client_sink_.write_ok);

  // The closing end hears closed(); the other end hears that its peer closed.
  client_->close("test over");
  ASSERT_TRUE(loop_.runUntil([&] { return client_sink_.closed_ && server_sink_.end; }, kWait));
  EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::peer_closed);
  EXPECT_FALSE(client_sink_.end);
}

TEST_F(TransportPair, TcpNamesItsPeerByAddressAndRefusesATlsClient) {
  connect(Address{.kind = Address::Kind::tcp, .host = "127.0.0.1", .port = 0});
  exchange();
  EXPECT_EQ(server_->kind(), TransportKind::tcp);
  EXPECT_EQ(server_->peer().address, "127.0.0.1");
  EXPECT_EQ(server_->peer().source(), "tcp:127.0.0.1");
  EXPECT_FALSE(server_->passesDescriptors());
  EXPECT_GE(client_->descriptor(), 0);

  // A ClientHello on the plain port: refused, not read as a frame.
  server_.reset();
  client_.reset();
  server_sink_ = {};
  dial(Address{.kind = Address::Kind::tcp, .host = "127.0.0.1", .port = listener_->port()});
  const std::string_view hello("\x16\x03\x01\x00\x05hello", 10);
  ASSERT_TRUE(client_->tryWrite({&hello, 1}));
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.end.has_value(); }, kWait));
  EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::refused);
  EXPECT_TRUE(server_sink_.bytes.empty());
}

TEST_F(TransportPair, AUnixConnectionMovesToAnotherLoopMidStream) {
  connect(Address{.kind = Address::Kind::local, .path = (dir_.path() / "m.sock").string()});
  moveServerMidStream();
}

TEST_F(TransportPair, ATcpConnectionMovesToAnotherLoopMidStream) {
  connect(Address{.kind = Address::Kind::tcp, .host = "127.0.0.1", .port = 0});
  moveServerMidStream();
}

class TlsPair : public TransportPair {
 protected:
  void SetUp() override {
    certs_ = dir_.path() / "certs";
    const std::string cmd = std::string("sh ") + SKROBOT_SOURCE_DIR +
                            "/tests/support/make_test_certs.sh " + certs_.string() +
                            " >/dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
  }
  ListenOptions serverOptions() {
    flow::TlsSettings s;
    s.cert_file = (certs_ / "hub.pem").string();
    s.key_file = (certs_ / "hub.key").string();
    auto ctx = flow::TlsContext::create(flow::TlsRole::server, s);
    EXPECT_TRUE(ctx);
    ListenOptions o;
    o.tls = std::move(ctx).value();
    o.plain_peer_reply = "speak TLS";
    return o;
  }
  Result<flow::TlsContext> clientContext() {
    flow::TlsSettings c;
    c.ca_file = (certs_ / "ca.pem").string();
    return flow::TlsContext::create(flow::TlsRole::client, c);
  }
  std::filesystem::path certs_;
};

TEST_F(TlsPair, TlsCarriesBytesBothWaysAndNamesTheCertificate) {
  const auto client_tls = clientContext();
  ASSERT_TRUE(client_tls);
  connect(Address{.kind = Address::Kind::tls, .host = "localhost", .port = 0}, serverOptions(),
          &client_tls);
  exchange();
  const std::string_view back[] = {"and ", "back"};
  ASSERT_TRUE(server_->write(back));
  ASSERT_TRUE(loop_.runUntil(
      [&] { return server_sink_.writes == 1 && client_sink_.bytes == "and back"; }, kWait));
  EXPECT_EQ(server_->kind(), TransportKind::tls);
  EXPECT_EQ(server_->peer().source(),
            server_->peer().address.empty() ? "tcp:?" : "tcp:" + server_->peer().address);
  EXPECT_NE(client_->peer().certificate.find("CN="), std::string::npos)
      << client_->peer().certificate;
  EXPECT_EQ(server_->descriptor(), -1);  // bytes are transformed: no zero-copy calls

  // close_notify: the peer hears a close, not a cut connection.
  client_->close("done");
  ASSERT_TRUE(loop_.runUntil([&] { return server_sink_.end.has_value(); }, kWait));
  EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::peer_closed);
  EXPECT_EQ(server_sink_.end->message, "peer closed TLS");
}

// The session moves with the socket: ciphertext that arrived during the move is decrypted over
// there, the moved end encrypts in the same session, and its close is a close_notify.
TEST_F(TlsPair, ATlsConnectionMovesToAnotherLoopMidStream) {
  const auto client_tls = clientContext();
  ASSERT_TRUE(client_tls);
  connect(Address{.kind = Address::Kind::tls, .host = "localhost", .port = 0}, serverOptions(),
          &client_tls);
  moveServerMidStream();
}

TEST_F(TlsPair, APlainClientIsToldInPlainAndRefused) {
  auto options = serverOptions();
  auto l = Listener::open(
      loop_, Address{.kind = Address::Kind::tls, .host = "127.0.0.1", .port = 0},
      std::move(options), [this](std::unique_ptr<Transport> t) { server_ = std::move(t); });
  ASSERT_TRUE(l);
  listener_ = std::move(l).value();
  std::optional<Result<std::unique_ptr<Transport>>> opened;
  auto dialer = Dialer::open(
      loop_, Address{.kind = Address::Kind::tcp, .host = "127.0.0.1", .port = listener_->port()},
      nullptr, [&](auto r) { opened.emplace(std::move(r)); });
  ASSERT_TRUE(loop_.runUntil([&] { return opened && server_; }, kWait));
  ASSERT_TRUE(*opened);
  client_ = std::move(opened->value());
  ASSERT_TRUE(client_->start(client_sink_));
  ASSERT_TRUE(server_->start(server_sink_));
  const std::string_view plain = "plain LOGIN";
  ASSERT_TRUE(client_->tryWrite({&plain, 1}));
  ASSERT_TRUE(
      loop_.runUntil([&] { return server_sink_.end && client_sink_.bytes == "speak TLS"; }, kWait));
  EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::refused);
}

TEST_F(TlsPair, ADialerReportsAFailedHandshake) {
  auto wrong = flow::TlsContext::create(flow::TlsRole::client, flow::TlsSettings{});  // system CAs
  ASSERT_TRUE(wrong);
  auto l =
      Listener::open(loop_, Address{.kind = Address::Kind::tls, .host = "127.0.0.1", .port = 0},
                     serverOptions(), [this](std::unique_ptr<Transport> t) {
                       server_ = std::move(t);
                       ASSERT_TRUE(server_->start(server_sink_));
                     });
  ASSERT_TRUE(l);
  listener_ = std::move(l).value();
  std::optional<Result<std::unique_ptr<Transport>>> opened;
  auto dialer = Dialer::open(
      loop_, Address{.kind = Address::Kind::tls, .host = "localhost", .port = listener_->port()},
      &wrong, [&](auto r) { opened.emplace(std::move(r)); });
  ASSERT_TRUE(loop_.runUntil([&] { return opened && server_sink_.end; }, kWait));
  ASSERT_FALSE(*opened);
  EXPECT_NE(opened->error().message.find("TLS with tls:localhost:"), std::string::npos)
      << opened->error().message;
  EXPECT_EQ(server_sink_.end->why, TransportEnd::Why::refused);
}

// --- a message-based transport under the hub's Connection -------------------------------------

// Test-only: each message is one frame. What the connection writes is checked to be whole frames
// and kept one message per frame.
class MemoryTransport final : public Transport {
 public:
  struct Wire {
    Receiver* rx = nullptr;
    std::vector<std::string> sent;  // one message per frame, hub to test
    bool broken_frame = false;      // a write that was not whole frames
    bool closed = false;
  };
  MemoryTransport(Loop& loop, std::shared_ptr<Wire> wire)
      : wire_(std::move(wire)), later_(loop, [this] { fire(); }) {}

  [[nodiscard]] TransportKind kind() const noexcept override { return TransportKind::memory; }
  [[nodiscard]] Framing framing() const noexcept override { return Framing::messages; }
  Result<void> start(Receiver& r) override {
    wire_->rx = &r;
    return {};
  }
  void pause() noexcept override {}
  Result<void> resume() override { return {}; }
  Result<size_t> tryWrite(std::span<const std::string_view> buffers) override {
    size_t n = 0;
    for (std::string_view b : buffers) {
      n += b.size();
      while (!b.empty()) {
        uint32_t len = 0;
        if (b.size() >= 4) std::memcpy(&len, b.data(), 4);
        if (b.size() < 5 || b.size() < len + size_t{4}) {
          wire_->broken_frame = true;
          break;
        }
        wire_->sent.emplace_back(b.substr(0, len + 4));
        b.remove_prefix(len + 4);
      }
    }
    return n;
  }
  Result<void> write(std::span<const std::string_view> buffers) override {
    (void)tryWrite(buffers);
    written_ = true;
    later_.startIn(0);
    return {};
  }
  void close(std::string_view) noexcept override {
    wire_->closed = true;
    closing_ = true;
    later_.startIn(0);
  }
  [[nodiscard]] PeerIdentity peer() const override {
    return {.kind = TransportKind::memory, .address = "memory"};
  }
  [[nodiscard]] uint32_t maxFrameBytes() const noexcept override { return 64 * 1024; }

 private:
  void fire() {
    if (closing_) {
      wire_->rx->closed();  // destroys this
      return;
    }
    if (written_) {
      written_ = false;
      wire_->rx->written({});
    }
  }
  std::shared_ptr<Wire> wire_;
  Timer later_;
  bool written_ = false;
  bool closing_ = false;
};

TEST(MessageTransport, TheHubsConnectionRunsOverOneFramePerMessage) {
  TempDir dir("transport-test");
  auto users = flow::UsersFile::load(dir.path() / "users.json");
  ASSERT_TRUE(users);
  ASSERT_TRUE(users->add("alice", "s3cret-pass"));
  ASSERT_TRUE(users->save());
  Loop loop;
  flow::ServerOptions o;
  o.app_name = "skrobot-transport-" + std::to_string(::getpid());
  o.unix_path = (dir.path() / "hub.sock").string();
  o.data_dir = dir.path() / "data";
  o.users_file = dir.path() / "users.json";
  auto hub = std::make_unique<flow::FlowServer::Impl>(loop, o);
  ASSERT_TRUE(hub->start());

  auto wire = std::make_shared<MemoryTransport::Wire>();
  hub->accept(std::make_unique<MemoryTransport>(loop, wire));
  ASSERT_NE(wire->rx, nullptr);
  // LOGIN then GO_ASYNC, one message each; each reply arrives as one message.
  std::string login, go;
  msg::Login m;
  m.user = "alice";
  m.password = "s3cret-pass";
  ASSERT_TRUE(flow::encode(login, m));
  flow::appendHeader(go, flow::Code::go_async, 0);
  wire->rx->message(login);
  ASSERT_TRUE(loop.runUntil([&] { return !wire->sent.empty(); }, kWait));
  ASSERT_EQ(wire->sent.size(), 1u);
  EXPECT_EQ(static_cast<uint8_t>(wire->sent[0][4]), uint8_t(flow::Code::reply_ok));
  wire->rx->message(go);
  ASSERT_TRUE(loop.runUntil([&] { return wire->sent.size() >= 2; }, kWait));
  EXPECT_EQ(static_cast<uint8_t>(wire->sent[1][4]), uint8_t(flow::Code::reply_ok));
  EXPECT_FALSE(wire->broken_frame);

  // Two frames in one message break the rule: that connection closes (FLOW-PROTOCOL).
  wire->rx->message(go + go);
  ASSERT_TRUE(loop.runUntil([&] { return wire->closed; }, kWait));
  EXPECT_EQ(hub->stats.protocol_errors, 1u);
  hub->stop();
  hub.reset();
  loop.runFor(10 * kNsPerMs);
}

}  // namespace
}  // namespace skr::test
