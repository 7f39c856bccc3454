// SPDX-License-Identifier: Apache-2.0
// The FlowServer's TLS listener in process: bad files stop the start; frames inside TLS go
// through the same frame splitter (a bad length still closes that connection with
// FLOW-PROTOCOL); a plain client gets a plain REPLY_ERROR; garbage records are refused; the
// server goes on; a blob transfer moves the session to an I/O thread. Clients here are blocking
// sockets with skr::flow::TlsSession, and the satellite library's SyncClient.
#include "flow_fixture.h"

#include <skrobot/satellite/sync_client.h>

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/flow/tls.h>

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>

namespace skr::test {
namespace {

using flow::Code;
namespace msg = flow::msg;

// A blocking TCP connection to 127.0.0.1, optionally with TLS.
class Conn {
 public:
  explicit Conn(uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~Conn() { ::close(fd_); }
  Conn(const Conn&) = delete;
  Conn& operator=(const Conn&) = delete;
  Conn(Conn&&) = delete;
  Conn& operator=(Conn&&) = delete;

  [[nodiscard]] bool connected() const { return connected_; }

  // The handshake; the error message, or "" once established.
  std::string handshake(const flow::TlsContext& ctx) {
    auto s = flow::TlsSession::open(ctx, "localhost");
    if (!s) return s.error().message;
    tls_.emplace(std::move(s).value());
    for (int i = 0; i < 20; ++i) {
      flushTls();
      if (tls_->established()) return {};
      std::string in;
      if (!recvRaw(in)) return "closed during the handshake";
      if (auto r = tls_->receive(in); !r) return r.error().message;
    }
    return "handshake did not finish";
  }
  void send(std::string_view bytes) {
    if (!tls_) {
      (void)!::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      return;
    }
    ASSERT_TRUE(tls_->write(bytes));
    flushTls();
  }
  // The next frame's code and body (decrypted), or nullopt when the peer closed.
  std::optional<std::pair<uint8_t, std::string>> frame() {
    const flow::FrameSplitter splitter(flow::kDefaultMaxFrameBytes);
    for (;;) {
      const auto n = splitter.next(reinterpret_cast<const uint8_t*>(plain_.data()), plain_.size());
      if (n.status == flow::FrameSplitter::Status::frame) {
        std::pair<uint8_t, std::string> f{n.code, std::string(n.body)};
        plain_.erase(0, n.consumed);
        return f;
      }
      std::string in;
      if (!recvRaw(in)) return std::nullopt;
      if (!tls_) {
        plain_ += in;
        continue;
      }
      if (!tls_->receive(in)) return std::nullopt;
      char buf[16384];
      for (;;) {
        auto got = tls_->read(buf, sizeof buf);
        if (!got || *got == 0) break;
        plain_.append(buf, *got);
      }
    }
  }
  // True when the peer closes within 5 s (whatever it sent before).
  bool closedByPeer() {
    for (;;) {
      std::string in;
      if (!recvRaw(in)) return eof_;
    }
  }

 private:
  void flushTls() {
    std::string out;
    tls_->takeOutput(out);
    if (!out.empty()) (void)!::send(fd_, out.data(), out.size(), MSG_NOSIGNAL);
  }
  bool recvRaw(std::string& in) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 5000) <= 0) return false;
    char buf[65536];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n <= 0) {
      eof_ = true;
      return false;
    }
    in.append(buf, static_cast<size_t>(n));
    return true;
  }

  int fd_ = -1;
  bool connected_ = false;
  bool eof_ = false;
  std::optional<flow::TlsSession> tls_;
  std::string plain_;
};

class TlsServer : public FlowFixture {
 protected:
  void SetUp() override {
    certs_ = dir_.path() / "certs";
    const std::string cmd = std::string("sh ") + SKROBOT_SOURCE_DIR +
                            "/tests/support/make_test_certs.sh " + certs_.string() +
                            " >/dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    flow::TlsSettings client;
    client.ca_file = file("ca.pem");
    auto c = flow::TlsContext::create(flow::TlsRole::client, client);
    ASSERT_TRUE(c) << c.error().message;
    client_.emplace(std::move(c).value());
    auto users = flow::UsersFile::load(dir_.path() / "users.json");
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->add("alice", "s3cret-pass"));
    ASSERT_TRUE(users->save());
  }
  std::string file(const char* name) const { return (certs_ / name).string(); }
  flow::ServerOptions tlsOptions(const char* cert = "hub.pem", const char* key = "hub.key") {
    flow::ServerOptions o = defaults();
    o.tcp_enabled = true;
    o.tcp_port = 0;
    o.users_file = dir_.path() / "users.json";
    o.tls.emplace();
    o.tls->cert_file = file(cert);
    o.tls->key_file = file(key);
    return o;
  }
  uint16_t port() {
    uint16_t p = 0;
    onHub([&] { p = server_->tcpPort(); });
    return p;
  }
  static std::string loginFrame() {
    msg::Login m;
    m.user = "alice";
    m.password = "s3cret-pass";
    std::string out;
    EXPECT_TRUE(flow::encode(out, m));
    return out;
  }

  std::filesystem::path certs_;
  std::optional<flow::TlsContext> client_;
};

TEST_F(TlsServer, BadFilesStopTheStartNamingThem) {
  auto r = startHub(tlsOptions("missing.pem"));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::config_error);
  EXPECT_NE(r.error().message.find("missing.pem"), std::string::npos) << r.error().message;
  stopHub();
  r = startHub(tlsOptions("hub.pem", "wrong-host.key"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("wrong-host.key: key values mismatch"), std::string::npos)
      << r.error().message;
}

TEST_F(TlsServer, FramesInsideTlsGoThroughTheFrameSplitter) {
  ASSERT_TRUE(startHub(tlsOptions()));
  Conn c(port());
  ASSERT_TRUE(c.connected());
  ASSERT_EQ(c.handshake(*client_), "");
  c.send(loginFrame());
  auto ok = c.frame();
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->first, uint8_t(Code::reply_ok));
  // A frame announcing 4 GiB, inside TLS: the splitter refuses it before allocating.
  c.send(std::string("\xff\xff\xff\xff\x01", 5));
  EXPECT_TRUE(c.closedByPeer());
  EXPECT_EQ(stats().protocol_errors, 1u);
  EXPECT_EQ(stats().tls_refused, 0u);

  // The server goes on.
  Conn d(port());
  ASSERT_EQ(d.handshake(*client_), "");
  d.send(loginFrame());
  auto ok2 = d.frame();
  ASSERT_TRUE(ok2);
  EXPECT_EQ(ok2->first, uint8_t(Code::reply_ok));
}

TEST_F(TlsServer, PlainClientsAndGarbageRecordsAreRefused) {
  ASSERT_TRUE(startHub(tlsOptions()));
  {
    Conn plain(port());
    plain.send(loginFrame());
    auto reply = plain.frame();  // not encrypted: the client understands it
    ASSERT_TRUE(reply);
    ASSERT_EQ(reply->first, uint8_t(Code::reply_error));
    auto e = flow::decode<msg::ReplyError>(reply->second);
    ASSERT_TRUE(e);
    EXPECT_EQ(e->error, uint16_t(flow::ErrorCode::protocol_error));
    EXPECT_NE(e->message.find("speaks TLS"), std::string::npos) << e->message;
    EXPECT_TRUE(plain.closedByPeer());
  }
  EXPECT_EQ(stats().tls_refused, 1u);
  {
    // A handshake record header followed by garbage.
    Conn garbage(port());
    garbage.send(std::string("\x16\x03\x01\x00\x05hello", 10));
    EXPECT_TRUE(garbage.closedByPeer());
  }
  EXPECT_EQ(stats().tls_refused, 2u);
  Conn good(port());
  ASSERT_EQ(good.handshake(*client_), "");
  good.send(loginFrame());
  auto ok = good.frame();
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->first, uint8_t(Code::reply_ok));
  EXPECT_EQ(stats().protocol_errors, 0u);
}

}  // namespace
}  // namespace skr::test

namespace skr::test {
namespace {

// A synchronous connection's TLS session moves to an I/O thread with its socket at the first
// blob request (core/src/flow/io_relay.h), and the transfer goes on inside the same session.
TEST_F(TlsServer, ABlobTransferMovesTheTlsSessionToAnIoThread) {
  ASSERT_TRUE(startHub(tlsOptions()));
  sat::ConnectOptions o;
  o.address.kind = flow::Address::Kind::tls;
  o.address.host = "localhost";
  o.address.port = port();
  o.user = "alice";
  o.password = "s3cret-pass";
  o.tls.ca_file = file("ca.pem");
  auto c = sat::SyncClient::connect(o);
  ASSERT_TRUE(c) << c.error().message;
  ASSERT_TRUE(c->ping());
  auto ch = c->createBlobChannel("maps");
  ASSERT_TRUE(ch) << ch.error().message;
  EXPECT_EQ(stats().connections_moved, 1u);
  std::string data(3 * sat::SyncClient::kBlobChunk + 5, '\0');
  for (size_t i = 0; i < data.size(); ++i) data[i] = char(i * 31 + i / 4096);
  ASSERT_TRUE(c->blobPut(ch->id, "map.bin", data));
  auto back = c->blobGet(ch->id, "map.bin");
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_TRUE(*back == data);
  ASSERT_TRUE(c->ping());
  EXPECT_EQ(stats().protocol_errors, 0u);
  EXPECT_EQ(stats().tls_refused, 0u);
}

}  // namespace
}  // namespace skr::test
