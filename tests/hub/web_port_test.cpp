// SPDX-License-Identifier: Apache-2.0
// The hub's web port (server.web) against a real hub: files from the root and a mount with their
// security headers, GET and HEAD, keep-alive; what must not be served (paths that leave the tree
// by "..", "%2e%2e" or a symlink, dot files) answered 404; a Host that is not the hub's (DNS
// rebinding) refused 403 and logged FLOW-WS-REFUSED; /flow refused for a foreign Origin, a
// missing subprotocol, or when flows are off.
#include "sat_fixture.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <regex>
#include <thread>

namespace skr::sat::test {
namespace {

using namespace std::chrono_literals;

struct Reply {
  int status = 0;
  std::string head;  // status line and headers
  std::string body;
  [[nodiscard]] bool has(const std::string& header_line) const {
    return head.find("\r\n" + header_line + "\r\n") != std::string::npos;
  }
};

// One TCP connection to the web port: requests written as given, answers read by Content-Length.
class Http {
 public:
  // To 127.0.0.1:`port`, from `from` (another loopback address) when given.
  explicit Http(uint16_t port, const char* from = nullptr) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    timeval tv{5, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    if (from != nullptr) {
      ::inet_pton(AF_INET, from, &a.sin_addr);
      if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return;
    }
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  // To a Unix socket (a hub's local: address, without "local:").
  explicit Http(const std::string& unix_path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    timeval tv{5, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    if (unix_path.size() >= sizeof a.sun_path) return;
    std::memcpy(a.sun_path, unix_path.data(), unix_path.size());
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~Http() { ::close(fd_); }
  Http(const Http&) = delete;
  Http& operator=(const Http&) = delete;
  Http(Http&&) = delete;
  Http& operator=(Http&&) = delete;

  [[nodiscard]] bool ok() const { return ok_; }
  void send(const std::string& text) { (void)!::write(fd_, text.data(), text.size()); }
  // The next answer; `head_only`: a HEAD's (no body follows whatever its Content-Length).
  Reply read(bool head_only = false) {
    Reply r;
    size_t end;
    while ((end = in_.find("\r\n\r\n")) == std::string::npos) {
      if (!more()) return r;
    }
    r.head = in_.substr(0, end + 2);
    in_.erase(0, end + 4);
    r.status = std::atoi(r.head.c_str() + 9);
    size_t length = 0;
    if (const size_t at = r.head.find("Content-Length: "); at != std::string::npos) {
      length = std::strtoull(r.head.c_str() + at + 16, nullptr, 10);
    }
    if (head_only || r.status == 101) return r;
    while (in_.size() < length) {
      if (!more()) break;
    }
    r.body = in_.substr(0, length);
    in_.erase(0, std::min(length, in_.size()));
    return r;
  }
  // What came after the last answer (a WebSocket's frames), reading until `until` is among it,
  // the peer closes, or 5 s pass.
  std::string rest(const std::string& until) {
    while (in_.find(until) == std::string::npos && more()) {
    }
    return in_;
  }
  // Whether the hub closed the connection (reads EOF within the timeout).
  bool closedByPeer() {
    while (more()) {
    }
    return eof_;
  }

 private:
  bool more() {
    char buf[65536];
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n == 0) eof_ = true;
    if (n <= 0) return false;
    in_.append(buf, static_cast<size_t>(n));
    return true;
  }
  int fd_ = -1;
  bool ok_ = false;
  bool eof_ = false;
  std::string in_;
};

Reply get(uint16_t port, const std::string& path, const std::string& more_headers = {},
          const std::string& method = "GET") {
  Http h(port);
  h.send(method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + more_headers +
         "Connection: close\r\n\r\n");
  return h.read(method == "HEAD");
}

// A client's binary WebSocket frame (masked, with a zero key) carrying `payload`.
std::string wsFrame(std::string_view payload) {
  std::string f(1, '\x82');
  if (payload.size() < 126) {
    f += static_cast<char>(0x80 | payload.size());
  } else {
    f += static_cast<char>(0x80 | 126);
    f += static_cast<char>(payload.size() >> 8);
    f += static_cast<char>(payload.size() & 0xFF);
  }
  f.append(4, '\0');
  f.append(payload);
  return f;
}

// A FlowProtocol frame of `m`.
template <class M>
std::string flowFrame(const M& m) {
  std::string out;
  EXPECT_TRUE(flow::encode(out, m));
  return out;
}

constexpr const char* kWsHeaders =
    "Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Version: 13\r\n"
    "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n";

class WebPort : public ::testing::Test {
 protected:
  void SetUp() override {
    site_ = dir_.path() / "site";
    fs::create_directories(site_ / "js");
    fs::create_directories(dir_.path() / "teleop");
    std::ofstream(site_ / "index.html") << "<p>robot</p>";
    std::ofstream(site_ / "js" / "app.js") << "export const x = 1;";
    std::ofstream(site_ / ".env") << "SECRET=1";
    std::ofstream(dir_.path() / "secret.txt") << "not for the web";
    std::ofstream(dir_.path() / "teleop" / "drive.js") << "drive();";
    fs::create_symlink(dir_.path() / "secret.txt", site_ / "link.txt");
    fs::create_directory_symlink(dir_.path(), site_ / "up");
    std::string big(600 * 1024, 'x');  // three chunks
    for (size_t i = 0; i < big.size(); i += 4096) big[i] = static_cast<char>('a' + i / 4096 % 26);
    big_ = big;
    std::ofstream(site_ / "big.bin") << big;
  }

  // A hub with the account alice, TCP, and the web port with `web_keys`; `server_keys` go into
  // "server".
  HubProcess* hub(const std::string& web_keys, const std::string& server_keys = {}) {
    const fs::path d = dir_.path() / ("hub" + std::to_string(hubs_.size() + 1));
    fs::create_directories(d);
    auto h = std::make_unique<HubProcess>(
        SKROBOT_BIN, d, "alice",
        R"(, "web": {"port": 0, "root": ")" + site_.string() + R"(", "mounts": {"/teleop": ")" +
            (dir_.path() / "teleop").string() + "\"}" + web_keys + "}" + server_keys);
    EXPECT_TRUE(h->start()) << h->log();
    hubs_.push_back(std::move(h));
    return hubs_.back().get();
  }
  // Each hub stops cleanly, without a sanitizer's report.
  void TearDown() override {
    for (auto& h : hubs_) {
      EXPECT_EQ(h->stop(), 0) << h->log();
      EXPECT_EQ(h->log().find("Sanitizer"), std::string::npos) << h->log();
      EXPECT_EQ(h->log().find("runtime error"), std::string::npos) << h->log();
    }
  }
  // The port of the hub's "FLOW-LISTEN HTTP 127.0.0.1:<port>" (or HTTPS) line; 0 without.
  static uint16_t webPort(const HubProcess& h) {
    const std::string text = h.log();
    const size_t at = text.find("FLOW-LISTEN HTTP");
    const size_t colon = at == std::string::npos ? at : text.find(':', at);
    return colon == std::string::npos ? 0
                                      : static_cast<uint16_t>(std::atoi(text.c_str() + colon + 1));
  }
  static ConnectOptions options(const std::string& address, const std::string& user = "alice",
                                const std::string& password = "s3cret-pass") {
    ConnectOptions o;
    o.address = Address::parse(address).value();
    o.user = user;
    o.password = password;
    o.client_name = "web-test";
    return o;
  }
  // "" when a flow logged in with `o`, else why not (the first disconnection's reason). The C++
  // library speaks flows only over ws: and wss: (no synchronous connection there).
  static std::string flowError(const ConnectOptions& o) {
    SatelliteOptions so;
    so.connection = o;
    SatOnThread sat(so);
    sat.start();
    const bool settled =
        eventually([&] { return sat.connected() || sat.events.count("error:") > 0; });
    if (sat.connected()) return {};
    if (!settled) return "neither connected nor refused";
    return sat.events.with("error:").front();
  }
  static size_t count(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
  }

  TempDir dir_;
  fs::path site_;
  std::string big_;
  std::vector<std::unique_ptr<HubProcess>> hubs_;
};

TEST_F(WebPort, ServesFilesWithSecurityHeadersGetHeadAndKeepAlive) {
  auto h = hub("");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();

  Reply index = get(port, "/");
  EXPECT_EQ(index.status, 200) << index.head;
  EXPECT_EQ(index.body, "<p>robot</p>");
  EXPECT_TRUE(index.has("Content-Type: text/html; charset=utf-8")) << index.head;
  EXPECT_TRUE(index.has("X-Content-Type-Options: nosniff")) << index.head;
  EXPECT_TRUE(index.has("Referrer-Policy: no-referrer")) << index.head;
  EXPECT_NE(index.head.find("Content-Security-Policy: default-src 'self';"), std::string::npos);
  EXPECT_NE(index.head.find("frame-ancestors 'none'"), std::string::npos);

  Reply js = get(port, "/js/app.js");
  EXPECT_EQ(js.status, 200);
  EXPECT_TRUE(js.has("Content-Type: text/javascript")) << js.head;
  EXPECT_EQ(js.body, "export const x = 1;");
  Reply mounted = get(port, "/teleop/drive.js");
  EXPECT_EQ(mounted.status, 200);
  EXPECT_EQ(mounted.body, "drive();");

  Reply head = get(port, "/js/app.js", {}, "HEAD");
  EXPECT_EQ(head.status, 200);
  EXPECT_TRUE(head.has("Content-Length: 19")) << head.head;

  // Keep-alive: three requests on one connection, the large file in several reads.
  Http conn(port);
  ASSERT_TRUE(conn.ok());
  for (const char* path : {"/index.html", "/big.bin", "/js/app.js"}) {
    conn.send(std::string("GET ") + path + " HTTP/1.1\r\nHost: localhost:8080\r\n\r\n");
    Reply r = conn.read();
    EXPECT_EQ(r.status, 200) << path;
    EXPECT_TRUE(r.has("Connection: keep-alive")) << r.head;
    if (std::string(path) == "/big.bin") {
      EXPECT_TRUE(r.body == big_) << r.body.size();
    }
  }
}

TEST_F(WebPort, NothingOutsideTheTreeNorDotFilesIsServed) {
  auto h = hub("");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  for (const char* path :
       {"/../secret.txt", "/%2e%2e/secret.txt", "/%2E%2E/secret.txt", "/js/..%2f..%2fsecret.txt",
        "/teleop/../../secret.txt", "/teleop/%2e%2e/secret.txt", "/link.txt", "/up/secret.txt",
        "/.env", "/js/%00app.js", "/nothing.html", "/teleop/nothing.js"}) {
    Reply r = get(port, path);
    EXPECT_EQ(r.status == 404 || r.status == 400, true) << path << ": " << r.head;
    EXPECT_EQ(r.body.find("not for the web"), std::string::npos) << path;
    EXPECT_EQ(r.body.find("SECRET"), std::string::npos) << path;
  }
  // The hub goes on serving.
  EXPECT_EQ(get(port, "/js/app.js").status, 200);
}

TEST_F(WebPort, AForeignHostIsRefusedAndLogged) {
  auto h = hub("");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  Http conn(port);
  conn.send("GET / HTTP/1.1\r\nHost: evil.example:8080\r\n\r\n");
  Reply r = conn.read();
  EXPECT_EQ(r.status, 403) << r.head;
  EXPECT_TRUE(conn.closedByPeer());
  EXPECT_TRUE(h->waitLog("FLOW-WS-REFUSED")) << h->log();
  EXPECT_NE(h->log().find("Host \"evil.example:8080\" is not a name of this hub"),
            std::string::npos)
      << h->log();
  // IP literals and localhost pass.
  Http v6(port);
  v6.send("GET / HTTP/1.1\r\nHost: [::1]:8080\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(v6.read().status, 200);
  Http local(port);
  local.send("GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(local.read().status, 200);
}

TEST_F(WebPort, FlowIsRefusedForAForeignOriginAWrongSubprotocolOrWhenOff) {
  {
    auto off = hub("");
    const uint16_t port = webPort(*off);
    Reply r =
        get(port, "/flow", std::string(kWsHeaders) + "Sec-WebSocket-Protocol: skrobot-flow.v1\r\n");
    EXPECT_EQ(r.status, 404) << r.head;
    EXPECT_TRUE(off->waitLog("(server.web.flows is off)")) << off->log();
  }
  auto h = hub(R"(, "flows": true, "hosts": ["robot.local"])");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  Reply origin =
      get(port, "/flow",
          std::string(kWsHeaders) +
              "Sec-WebSocket-Protocol: skrobot-flow.v1\r\nOrigin: http://evil.example\r\n");
  EXPECT_EQ(origin.status, 403) << origin.head;
  EXPECT_TRUE(h->waitLog("WebSocket from Origin \"http://evil.example\", not allowed")) << h->log();
  // The page's own origin is another scheme: refused too.
  Reply scheme =
      get(port, "/flow",
          std::string(kWsHeaders) +
              "Sec-WebSocket-Protocol: skrobot-flow.v1\r\nOrigin: https://127.0.0.1\r\n");
  EXPECT_EQ(scheme.status, 403) << scheme.head;
  Reply proto = get(port, "/flow", std::string(kWsHeaders) + "Sec-WebSocket-Protocol: chat\r\n");
  EXPECT_EQ(proto.status, 400) << proto.head;
  EXPECT_TRUE(h->waitLog("WebSocket on /flow without the subprotocol skrobot-flow.v1")) << h->log();
  Reply rebinding = [&] {
    Http c(port);
    c.send(std::string("GET /flow HTTP/1.1\r\nHost: attacker.example\r\n") + kWsHeaders +
           "Sec-WebSocket-Protocol: skrobot-flow.v1\r\n\r\n");
    return c.read();
  }();
  EXPECT_EQ(rebinding.status, 403);
  EXPECT_GE(count(h->log(), "FLOW-WS-REFUSED"), 4u) << h->log();

  // The page's own origin, with the subprotocol: the upgrade is accepted.
  Http ok(port);
  ok.send(std::string("GET /flow HTTP/1.1\r\nHost: robot.local:8080\r\n") + kWsHeaders +
          "Sec-WebSocket-Protocol: skrobot-flow.v1\r\nOrigin: http://robot.local:8080\r\n\r\n");
  Reply up = ok.read();
  EXPECT_EQ(up.status, 101) << up.head;
  EXPECT_TRUE(up.has("Sec-WebSocket-Protocol: skrobot-flow.v1")) << up.head;
}

TEST_F(WebPort, FlowsOverWsCarryData) {
  auto h = hub(R"(, "flows": true)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  const std::string ws = "ws:127.0.0.1:" + std::to_string(port);
  EXPECT_EQ(flowError(options(ws)), "") << h->log();
  EXPECT_NE(flowError(options(ws, "alice", "wrong")), "");

  // A publisher over WebSocket, a subscriber on the Unix socket: small frames and one above the
  // 256 KiB an output slice holds.
  SatelliteOptions po;
  po.connection = options(ws);
  po.connection.client_name = "pub";
  SatelliteOptions so;
  so.connection = options(h->address());
  so.connection.client_name = "sub";
  SatOnThread pub(po), sub(so);
  sub.on([](Satellite& s) { s.subscribe("alice.numbers"); });
  pub.start();
  sub.start();
  ASSERT_TRUE(eventually([&] { return pub.connected() && sub.connected(); })) << h->log();
  ASSERT_TRUE(pub.on([](Satellite& s) { return s.addChannel({.name = "numbers"}); }));
  ASSERT_TRUE(eventually([&] {
    return sub.events.count("subscribed:alice.numbers") == 1 &&
           pub.events.count("ready:alice.numbers") == 1;
  }));
  const std::string big(300000, 'x');
  pub.on([&](Satellite& s) {
    for (int i = 0; i < 100; ++i) ASSERT_TRUE(s.publish("numbers", std::to_string(i)));
    ASSERT_TRUE(s.publish("numbers", big));
  });
  ASSERT_TRUE(eventually([&] { return sub.events.count("data:alice.numbers:") == 101; }))
      << sub.events.count("data:alice.numbers:");
  const auto data = sub.events.with("data:alice.numbers:");
  EXPECT_EQ(data[0], "0");
  EXPECT_EQ(data[100], big);
  EXPECT_NE(h->log().find("(alice/pub) ws logged in"), std::string::npos) << h->log();
}

TEST_F(WebPort, FlowsOverWss) {
  const fs::path certs = dir_.path() / "certs";
  const std::string cmd =
      std::string("sh ") + MAKE_TEST_CERTS + " " + certs.string() + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << "make_test_certs.sh failed";
  auto h = hub(R"(, "flows": true)", R"(, "tls": {"cert": ")" + (certs / "hub.pem").string() +
                                         R"(", "key": ")" + (certs / "hub.key").string() + "\"}");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  EXPECT_NE(h->log().find("FLOW-LISTEN HTTPS"), std::string::npos) << h->log();
  ConnectOptions o = options("wss:localhost:" + std::to_string(port));
  o.tls.ca_file = (certs / "ca.pem").string();
  EXPECT_EQ(flowError(o), "") << h->log();
  // Plain HTTP to the HTTPS port is told so.
  Http plain(port);
  plain.send("GET / HTTP/1.1\r\nHost: localhost\r\n\r\n");
  Reply r = plain.read();
  EXPECT_EQ(r.status, 400) << r.head;
  EXPECT_NE(r.body.find("this port speaks HTTPS"), std::string::npos) << r.body;
}

TEST_F(WebPort, TheDevAccountOnlyWhenConfiguredAndFromLoopback) {
  {
    auto h = hub(R"(, "flows": true)");
    const uint16_t port = webPort(*h);
    ASSERT_NE(port, 0) << h->log();
    EXPECT_NE(flowError(options("ws:127.0.0.1:" + std::to_string(port), "guest", "password")), "");
    EXPECT_TRUE(h->waitLog("development account refused on websocket (loopback)")) << h->log();
  }
  auto h = hub(R"(, "flows": true, "dev_account": true)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  EXPECT_EQ(flowError(options("ws:127.0.0.1:" + std::to_string(port), "guest", "password")), "")
      << h->log();
  EXPECT_NE(h->log().find("on WebSocket from this machine (server.web.dev_account"),
            std::string::npos)
      << h->log();
  // Still never on TCP.
  EXPECT_NE(flowError(options(h->tcpAddress(), "guest", "password")), "");
}

// An upgraded /flow connection, raw: the test writes WebSocket frames itself.
std::unique_ptr<Http> rawFlow(uint16_t port, const char* from = nullptr) {
  auto c = std::make_unique<Http>(port, from);
  EXPECT_TRUE(c->ok()) << "cannot connect from " << (from != nullptr ? from : "127.0.0.1");
  c->send(std::string("GET /flow HTTP/1.1\r\nHost: 127.0.0.1\r\n") + kWsHeaders +
          "Sec-WebSocket-Protocol: skrobot-flow.v1\r\n\r\n");
  EXPECT_EQ(c->read().status, 101);
  return c;
}

TEST_F(WebPort, PhysicalPathsAreRefusedOnWebSocket) {
  auto h = hub(R"(, "flows": true)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  auto c = rawFlow(port);
  flow::msg::Login login;
  login.user = "alice";
  login.password = "s3cret-pass";
  login.client_name = "raw";
  c->send(wsFrame(flowFrame(login)));
  ASSERT_NE(c->rest("alice").find("alice"), std::string::npos) << "no LOGIN_OK";
  c->send(wsFrame(flowFrame(flow::msg::GoAsync{})));
  flow::msg::PhysOffer offer;
  offer.tag = 7;
  offer.chan_id = 1;
  offer.paths = 1;
  c->send(wsFrame(flowFrame(offer)));
  EXPECT_NE(c->rest("over WebSocket").find("PHYS_OFFER: no physical paths over WebSocket"),
            std::string::npos);
}

TEST_F(WebPort, AFrameOverTheLimitClosesOnlyThatConnection) {
  auto h = hub(R"(, "flows": true)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  SatelliteOptions so;
  so.connection = options("ws:127.0.0.1:" + std::to_string(port));
  SatOnThread good(so);
  good.start();
  ASSERT_TRUE(eventually([&] { return good.connected(); })) << h->log();
  // Before login a frame may hold 4096 bytes: this one announces 1 GiB.
  auto bad = rawFlow(port);
  bad->send(wsFrame(std::string("\x00\x00\x00\x40\x01", 5)));
  EXPECT_TRUE(bad->closedByPeer());
  EXPECT_TRUE(h->waitLog("FLOW-PROTOCOL")) << h->log();
  EXPECT_TRUE(good.connected());
  EXPECT_EQ(good.events.count("disconnected:"), 0u);
}

TEST_F(WebPort, ASlowWebSocketSubscriberDropsWhileAnotherKeepsUp) {
  auto h = hub(R"(, "flows": true)", R"(, "subscriber_queue_bytes": 65536)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  const std::string ws = "ws:127.0.0.1:" + std::to_string(port);
  SatelliteOptions po, fo, lo;
  po.connection = options(ws);
  po.connection.client_name = "pub";
  fo.connection = options(ws);
  fo.connection.client_name = "fast";
  lo.connection = options(ws);
  lo.connection.client_name = "slow";
  SatOnThread pub(po), fast(fo), slow(lo);
  // The fast one asks for a queue that holds everything (SUBSCRIBE_QUEUE): whatever the load on
  // the machine, it loses nothing; the slow one has the hub's 64 KiB.
  fast.on([](Satellite& x) { x.subscribe("alice.frames", 32u << 20); });
  slow.on([](Satellite& x) { x.subscribe("alice.frames"); });
  for (SatOnThread* s : {&pub, &fast, &slow}) s->start();
  ASSERT_TRUE(eventually([&] { return pub.connected() && fast.connected() && slow.connected(); }));
  ASSERT_TRUE(pub.on([](Satellite& s) { return s.addChannel({.name = "frames"}); }));
  ASSERT_TRUE(eventually([&] {
    return fast.events.count("subscribed:alice.frames") == 1 &&
           slow.events.count("subscribed:alice.frames") == 1;
  }));
  // ...and the hub has both SUBSCRIBEs ("subscribed" says one was sent), so that the fast one
  // misses none of the frames.
  auto local = SyncClient::connect(options(h->address()));  // (no synchronous client on ws:)
  ASSERT_TRUE(local) << local.error().message;
  ASSERT_TRUE(eventually([&] {
    auto c = local->channel("alice.frames");
    return c && c->subscribers == 2u;
  }));
  // The slow one's loop stops reading for 3 s while 400 frames of 64 KiB go out, paced so that
  // the publisher's own queue takes each (a publish it refuses is not counted).
  std::thread stall([&] { slow.on([](Satellite&) { std::this_thread::sleep_for(3s); }); });
  std::this_thread::sleep_for(100ms);
  const std::string frame(64 * 1024, 'f');
  size_t sent = 0;
  for (int i = 0; i < 400; ++i) {
    if (pub.on([&](Satellite& s) { return s.publish("frames", frame); })) ++sent;
    std::this_thread::sleep_for(2ms);
  }
  stall.join();
  ASSERT_GT(sent, 100u);
  ASSERT_TRUE(eventually([&] { return fast.events.count("data:alice.frames:") == sent; }))
      << fast.events.count("data:alice.frames:") << " of " << sent;
  EXPECT_TRUE(h->waitLog("FLOW-SLOW-SUBSCRIBER")) << h->log();
  EXPECT_NE(h->log().find("(alice/slow) ws: dropped"), std::string::npos) << h->log();
  std::this_thread::sleep_for(500ms);
  EXPECT_LT(slow.events.count("data:alice.frames:"), sent);
  EXPECT_TRUE(slow.connected());
}

TEST_F(WebPort, PageTokensAreIssuedByPostToTheHubsOwnPagesOnly) {
  {
    auto off = hub("");
    Reply r = get(webPort(*off), "/skrobot/token", "Content-Length: 0\r\n", "POST");
    EXPECT_EQ(r.status, 405) << r.head;  // files only: POST is not served
  }
  auto h = hub(R"(, "flows": true, "token_ttl_ms": 1000)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  Reply ok = get(port, "/skrobot/token",
                 "Content-Length: 0\r\nOrigin: http://127.0.0.1\r\nSec-Fetch-Site: same-origin\r\n",
                 "POST");
  EXPECT_EQ(ok.status, 200) << ok.head;
  EXPECT_TRUE(ok.has("Cache-Control: no-store")) << ok.head;
  EXPECT_TRUE(ok.has("Content-Type: application/json")) << ok.head;
  EXPECT_EQ(ok.head.find("Access-Control-"), std::string::npos) << ok.head;
  EXPECT_TRUE(std::regex_match(
      ok.body,
      std::regex(R"(\{"token":"[A-Za-z0-9_-]{43}","user":"web-page","expires_in_ms":1000\})")))
      << ok.body;
  // No Origin (Node.js, curl) passes too.
  EXPECT_EQ(get(port, "/skrobot/token", "Content-Length: 0\r\n", "POST").status, 200);

  Reply foreign = get(port, "/skrobot/token", "Origin: http://evil.example\r\n", "POST");
  EXPECT_EQ(foreign.status, 403) << foreign.head;
  EXPECT_EQ(foreign.body.find("token\""), std::string::npos);
  Reply cross = get(port, "/skrobot/token", "Sec-Fetch-Site: cross-site\r\n", "POST");
  EXPECT_EQ(cross.status, 403) << cross.head;
  EXPECT_EQ(get(port, "/skrobot/token").status, 405);
  EXPECT_EQ(get(port, "/skrobot/token", "Content-Length: 5\r\n", "POST").status, 400);
  EXPECT_TRUE(h->waitLog("page token for Origin \"http://evil.example\", not allowed")) << h->log();
}

TEST_F(WebPort, HttpConnectionsBeyondMaxConnectionsAreClosed) {
  auto h = hub("", R"(, "max_connections": 3)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  Http a(port), b(port), c(port);
  // Accepted in the order they connected: the fourth is one too many.
  Http d(port);
  EXPECT_TRUE(d.closedByPeer());
  EXPECT_TRUE(h->waitLog("HTTP connections already (server.max_connections)")) << h->log();
  a.send("GET /js/app.js HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  EXPECT_EQ(a.read().status, 200);
}

TEST_F(WebPort, WithoutARootThePageBesideTheHubIsServed) {
  // In a build tree: <build>/web, the page copied beside bin/ (installed: share/skrobot/web).
  const fs::path page = fs::path(SKROBOT_BIN).parent_path().parent_path() / "web";
  ASSERT_TRUE(fs::is_regular_file(page / "index.html")) << page;
  fs::create_directories(dir_.path() / "default");
  HubProcess h(SKROBOT_BIN, dir_.path() / "default", "alice", R"(, "web": {"port": 0})");
  ASSERT_TRUE(h.start()) << h.log();
  EXPECT_NE(h.log().find("(files from " + page.lexically_normal().string() + ")"),
            std::string::npos)
      << h.log();
  std::ifstream in(page / "index.html", std::ios::binary);
  const std::string index{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  Reply r = get(webPort(h), "/");
  EXPECT_EQ(r.status, 200) << r.head;
  EXPECT_TRUE(r.body == index);
}

TEST_F(WebPort, ThePageAccountIsCheckedAtStart) {
  // The hub's exit code and output with a config of the web port with `web_keys`, and
  // `user` in its users file.
  const auto run = [&](const std::string& name, const std::string& user,
                       const std::string& web_keys) {
    const fs::path d = dir_.path() / name;
    fs::create_directories(d);
    const HubProcess config(SKROBOT_BIN, d, user,
                            R"(, "web": {"port": 0, "flows": true, "root": ")" + site_.string() +
                                "\"" + web_keys + "}");
    Child hub({SKROBOT_BIN, "--config", (d / "hub.json").string()}, {}, d / "run.log");
    const int code = hub.wait(20000);
    return std::make_pair(code, hub.output());
  };
  // A users-file account named like the built-in page account.
  const auto clash = run("clash", "web-page", "");
  EXPECT_NE(clash.first, 0);
  EXPECT_NE(clash.second.find("the name of the built-in page account (server.web.page_account)"),
            std::string::npos)
      << clash.second;
  // A page account that the users file lacks.
  const auto missing = run("missing", "alice", R"(, "page_account": "teleop")");
  EXPECT_NE(missing.first, 0);
  EXPECT_NE(
      missing.second.find("server.web.page_account \"teleop\" is not an account of the users file"),
      std::string::npos)
      << missing.second;
  // Named, it is used: the hub starts.
  fs::create_directories(dir_.path() / "named");
  HubProcess named(SKROBOT_BIN, dir_.path() / "named", "alice",
                   R"(, "web": {"port": 0, "flows": true, "page_account": "alice", "root": ")" +
                       site_.string() + "\"}");
  EXPECT_TRUE(named.start()) << named.log();
}

// A page token from POST /skrobot/token (fetched from 127.0.0.1).
std::string pageToken(uint16_t port) {
  Reply r = get(port, "/skrobot/token", "Content-Length: 0\r\n", "POST");
  std::smatch m;
  if (r.status != 200 || !std::regex_search(r.body, m, std::regex(R"re("token":"([^"]+)")re"))) {
    ADD_FAILURE() << "no page token: " << r.head << r.body;
    return {};
  }
  return m[1];
}

flow::msg::LoginToken tokenLogin(const std::string& token) {
  flow::msg::LoginToken login;
  login.token = token;
  login.client_name = "page";
  return login;
}

// LOGIN_TOKEN on a raw WebSocket flow: its LOGIN_OK's user, or "refused" (REPLY_ERROR and the
// hub closes), or what else came.
std::string tokenLoginOverWs(uint16_t port, const std::string& token, const char* from = nullptr) {
  auto c = rawFlow(port, from);
  c->send(wsFrame(flowFrame(tokenLogin(token))));
  const std::string in = c->rest("web-page");
  if (in.find("web-page") != std::string::npos) return "web-page";
  if (in.find("wrong user name or password") != std::string::npos && c->closedByPeer()) {
    return "refused";
  }
  return "unexpected: " + in;
}

// A page logs in with a token over WebSocket, as the page account, any number of times from the
// address that fetched it; from another address, once expired, or on the Unix socket or TCP, it
// is a failed login (auth_failed, FLOW-AUTH-FAILED).
TEST_F(WebPort, APageTokenLogsInOverWebSocketOnlyFromItsAddressUntilItExpires) {
  auto h = hub(R"(, "flows": true, "token_ttl_ms": 1000)");
  const uint16_t port = webPort(*h);
  ASSERT_NE(port, 0) << h->log();
  const std::string token = pageToken(port);
  EXPECT_EQ(tokenLoginOverWs(port, token), "web-page") << h->log();
  EXPECT_EQ(tokenLoginOverWs(port, token), "web-page") << "a second login with it";
  EXPECT_TRUE(h->waitLog("(web-page/page)")) << h->log();

  // Fetched from 127.0.0.1, used from 127.0.0.2 (loopback too).
  EXPECT_EQ(tokenLoginOverWs(port, token, "127.0.0.2"), "refused") << h->log();
  EXPECT_TRUE(h->waitLog("refused (page token fetched from another address)")) << h->log();
  EXPECT_EQ(tokenLoginOverWs(port, "not-a-token"), "refused");
  EXPECT_TRUE(h->waitLog("refused (not a page token)")) << h->log();

  const std::string soon_old = pageToken(port);
  std::this_thread::sleep_for(1100ms);
  EXPECT_EQ(tokenLoginOverWs(port, soon_old), "refused") << h->log();
  EXPECT_TRUE(h->waitLog("refused (expired page token)")) << h->log();

  // A live token on the Unix socket and on TCP: the transport refuses it.
  const std::string fresh = pageToken(port);
  for (const std::string& address : {h->address(), h->tcpAddress()}) {
    const bool unix_socket = address.starts_with("local:");
    Http c = unix_socket
                 ? Http(address.substr(6))
                 : Http(static_cast<uint16_t>(std::atoi(address.c_str() + address.rfind(':') + 1)));
    ASSERT_TRUE(c.ok()) << address;
    c.send(flowFrame(tokenLogin(fresh)));
    EXPECT_NE(c.rest("wrong user").find("wrong user name or password"), std::string::npos)
        << address;
    EXPECT_TRUE(c.closedByPeer()) << address;
  }
  EXPECT_TRUE(h->waitLog("(a page token on unix socket (WebSocket only))")) << h->log();
  EXPECT_TRUE(h->waitLog("(a page token on tcp (WebSocket only))")) << h->log();
}

}  // namespace
}  // namespace skr::sat::test
