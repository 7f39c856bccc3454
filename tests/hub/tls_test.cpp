// SPDX-License-Identifier: Apache-2.0
// TLS on the TCP transport against real hubs: the satellite library (flow and synchronous
// connection, with a blob round trip) and flowctl over tls: addresses, and every refusal (plain TCP
// to the TLS port, TLS to a plain port, untrusted, expired, wrong-host and self-signed hub
// certificates, a missing or untrusted client certificate): a clear error to the client, a FLOW-TLS
// line in the hub's log, and the hub goes on serving. Certificates are made at test time
// (tests/support/make_test_certs.sh, openssl CLI).
#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

constexpr const char* kUser = "alice";
constexpr const char* kPassword = "s3cret-pass";

class Tls : public ::testing::Test {
 protected:
  void SetUp() override {
    certs_ = dir_.path() / "certs";
    const std::string cmd =
        std::string("sh ") + MAKE_TEST_CERTS + " " + certs_.string() + " >/dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << "make_test_certs.sh failed";
  }

  [[nodiscard]] std::string cert(const std::string& name) const { return (certs_ / name).string(); }
  // The "tls" server key naming certs/<name>.pem and .key; `client_ca` asks for client
  // certificates signed by it.
  [[nodiscard]] std::string tlsKeys(const std::string& name, const std::string& client_ca = {},
                                    const std::string& more = {}) const {
    std::string s = R"(, "tls": {"cert": ")" + cert(name + ".pem") + R"(", "key": ")" +
                    cert(name + ".key") + "\"";
    if (!client_ca.empty()) s += R"(, "client_ca": ")" + cert(client_ca) + "\"";
    return s + "}" + more;
  }
  // A running hub in its own folder, with the account alice and TCP (with `server_keys`).
  std::unique_ptr<HubProcess> hub(const std::string& name, const std::string& server_keys) {
    const fs::path d = dir_.path() / name;
    fs::create_directories(d);
    auto h = std::make_unique<HubProcess>(SKROBOT_BIN, d, kUser, server_keys);
    EXPECT_TRUE(h->start()) << h->log();
    return h;
  }
  [[nodiscard]] ConnectOptions options(const std::string& address, const std::string& ca,
                                       const std::string& client = {}) const {
    ConnectOptions o;
    o.address = Address::parse(address).value();
    o.user = kUser;
    o.password = kPassword;
    o.client_name = "tls-test";
    if (!ca.empty()) o.tls.ca_file = cert(ca);
    if (!client.empty()) {
      o.tls.cert_file = cert(client + ".pem");
      o.tls.key_file = cert(client + ".key");
    }
    return o;
  }
  // A synchronous connection's error message, or "" when it connected and answered.
  std::string syncError(const ConnectOptions& o) {
    auto c = SyncClient::connect(o);
    if (!c) return c.error().message;
    auto v = c->databases();
    return v ? std::string() : v.error().message;
  }
  static size_t refusals(const HubProcess& h) {
    const std::string text = h.log();
    size_t n = 0;
    for (size_t at = text.find("FLOW-TLS refusing"); at != std::string::npos;
         at = text.find("FLOW-TLS refusing", at + 1)) {
      ++n;
    }
    return n;
  }
  // The hub still serves: a good client logs in and reads a database.
  void expectServes(const HubProcess& h, const std::string& ca = "ca.pem",
                    const std::string& client = {}) {
    EXPECT_EQ(syncError(options(h.tlsAddress(), ca, client)), "") << h.log();
  }

  TempDir dir_;
  fs::path certs_;
};

TEST_F(Tls, SatellitesPublishSubscribeAndUseDatabasesOverTls) {
  auto h = hub("hub", tlsKeys("hub"));
  ASSERT_FALSE(h->tlsAddress().empty()) << h->log();
  EXPECT_NE(h->log().find("client certificates not asked for"), std::string::npos);

  auto sync = SyncClient::connect(options(h->tlsAddress(), "ca.pem"));
  ASSERT_TRUE(sync) << sync.error().message;
  ASSERT_TRUE(sync->set("colour", flow::Variant("green")));
  auto got = sync->get("colour");
  ASSERT_TRUE(got) << got.error().message;
  ASSERT_NE(got->asString(), nullptr);
  EXPECT_EQ(*got->asString(), "green");
  // A file of several chunks, each many records, up and down on the synchronous connection.
  std::string file(5 * SyncClient::kBlobChunk + 12345, '\0');
  for (size_t i = 0; i < file.size(); ++i) file[i] = char(i * 2654435761u >> 13);
  auto blobs = sync->createBlobChannel("files");
  ASSERT_TRUE(blobs) << blobs.error().message;
  ASSERT_TRUE(sync->blobPut(blobs->id, "a/file.bin", file));
  auto back = sync->blobGet(blobs->id, "a/file.bin");
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_TRUE(*back == file) << back->size();

  SatelliteOptions po;
  po.connection = options(h->tlsAddress(), "ca.pem");
  po.connection.client_name = "pub";
  SatelliteOptions so = po;
  so.connection.client_name = "sub";
  // Numeric hosts are checked against the certificate's IP addresses.
  so.connection.address = Address::parse(h->tlsAddress("127.0.0.1")).value();
  SatOnThread pub(po), sub(so);
  sub.on([](Satellite& s) { s.subscribe("alice.numbers"); });
  pub.start();
  sub.start();
  ASSERT_TRUE(eventually([&] { return pub.connected() && sub.connected(); })) << h->log();
  ASSERT_TRUE(pub.on([](Satellite& s) { return s.addChannel({.name = "numbers"}); }));
  // The subscriber may hear of the channel before the publisher's own loop has read its reply.
  ASSERT_TRUE(eventually([&] {
    return sub.events.count("subscribed:alice.numbers") == 1 &&
           pub.events.count("ready:alice.numbers") == 1;
  }));
  // Small frames batched into one record, and frames larger than a TLS record (16 KiB).
  const std::string big(300000, 'x');
  pub.on([&](Satellite& s) {
    for (int i = 0; i < 100; ++i) ASSERT_TRUE(s.publish("numbers", std::to_string(i)));
    ASSERT_TRUE(s.publish("numbers", big));
  });
  ASSERT_TRUE(eventually([&] { return sub.events.count("data:alice.numbers:") == 101; }))
      << sub.events.count("data:alice.numbers:");
  const auto data = sub.events.with("data:alice.numbers:");
  EXPECT_EQ(data[0], "0");
  EXPECT_EQ(data[99], "99");
  EXPECT_EQ(data[100], big);
  EXPECT_NE(h->log().find("(alice/pub) tls logged in"), std::string::npos) << h->log();
}

TEST_F(Tls, FlowctlWithCaOptionAndEnvironment) {
  auto h = hub("hub", tlsKeys("hub"));
  const std::string address = h->tlsAddress();
  const std::vector<std::string> login = {"ROBOT_USER=alice", "ROBOT_PASSWORD=s3cret-pass"};
  Child set({FLOWCTL_BIN, "--address", address, "--ca", cert("ca.pem"), "db", "set", "k", "42"},
            login, dir_.path() / "set.log");
  EXPECT_EQ(set.wait(), 0) << set.output();
  auto env = login;
  env.push_back("ROBOT_TLS_CA=" + cert("ca.pem"));
  env.push_back("ROBOT_ADDRESS=" + address);
  Child get({FLOWCTL_BIN, "db", "get", "k"}, env, dir_.path() / "get.log");
  EXPECT_EQ(get.wait(), 0) << get.output();
  EXPECT_EQ(get.output(), "42\n");
  // Without the CA the hub's certificate is not trusted (the system's store does not have it).
  Child untrusted({FLOWCTL_BIN, "--address", address, "ls"}, login, dir_.path() / "u.log");
  EXPECT_EQ(untrusted.wait(), 3) << untrusted.output();
  EXPECT_NE(untrusted.output().find("certificate verify failed"), std::string::npos)
      << untrusted.output();
  // A flow (echo) over TLS.
  Child echo({FLOWCTL_BIN, "--address", address, "--ca", cert("ca.pem"), "echo", "alice.none"},
             login, dir_.path() / "echo.log");
  EXPECT_EQ(echo.wait(), 5) << echo.output();  // connected, logged in, no such channel
}

TEST_F(Tls, PlainAndTlsMismatchesAreRefusedAndTheHubGoesOn) {
  auto tls = hub("tls", tlsKeys("hub"));
  // Plain TCP to the TLS port: the hub answers the LOGIN in the plain protocol.
  const std::string port = tls->tlsAddress().substr(tls->tlsAddress().rfind(':'));
  const std::string plain_error = syncError(options("tcp:localhost" + port, ""));
  EXPECT_NE(plain_error.find("this hub's TCP port speaks TLS"), std::string::npos) << plain_error;
  EXPECT_TRUE(eventually([&] {
    return tls->log().find("a plain TCP client on the TLS port") != std::string::npos;
  })) << tls->log();
  expectServes(*tls);

  // TLS to a plain port (reachable from other machines: the hub warns about that at start).
  auto plain = hub("plain", R"(, "tcp_address": "0.0.0.0")");
  EXPECT_NE(plain->log().find("FLOW-TCP-PLAIN"), std::string::npos) << plain->log();
  EXPECT_EQ(tls->log().find("FLOW-TCP-PLAIN"), std::string::npos);
  const std::string tcp = plain->tcpAddress();
  const std::string tls_error =
      syncError(options("tls:localhost" + tcp.substr(tcp.rfind(':')), "ca.pem"));
  EXPECT_NE(tls_error.find("the hub closed the connection during the handshake"), std::string::npos)
      << tls_error;
  EXPECT_TRUE(eventually([&] {
    return plain->log().find("FLOW-TLS refusing") != std::string::npos &&
           plain->log().find("a TLS client on the plain TCP port") != std::string::npos;
  })) << plain->log();
  EXPECT_EQ(syncError(options("tcp:127.0.0.1" + tcp.substr(tcp.rfind(':')), "")), "");
}

TEST_F(Tls, BadHubCertificatesAreRefusedWithTheirReason) {
  struct Case {
    const char* cert;
    const char* client_sees;
  };
  for (const Case& c :
       {Case{"expired", "certificate has expired"}, Case{"wrong-host", "hostname mismatch"},
        Case{"self-signed", "self-signed certificate"}}) {
    auto h = hub(c.cert, tlsKeys(c.cert));
    const std::string error = syncError(options(h->tlsAddress(), "ca.pem"));
    EXPECT_NE(error.find(c.client_sees), std::string::npos) << c.cert << ": " << error;
    // The hub logs the client's alert and goes on.
    EXPECT_TRUE(eventually([&] { return refusals(*h) == 1; })) << h->log();
    // A flow fails the same way, and keeps retrying in the background.
    SatelliteOptions so;
    so.connection = options(h->tlsAddress(), "ca.pem");
    SatOnThread s(so);
    s.start();
    EXPECT_TRUE(eventually([&] { return refusals(*h) >= 3; })) << h->log();
    EXPECT_FALSE(s.connected());
  }
  // The wrong-host certificate is good for its own name.
  auto h = hub("wrong-host-2", tlsKeys("wrong-host"));
  auto o = options(h->tlsAddress(), "ca.pem");
  o.address.host = "127.0.0.1";
  EXPECT_NE(syncError(o).find("IP address mismatch"), std::string::npos) << syncError(o);
}

TEST_F(Tls, ClientCertificatesWhenTheHubAsksForThem) {
  auto h = hub("hub", tlsKeys("hub", "ca.pem"));
  EXPECT_NE(h->log().find("client certificates required"), std::string::npos) << h->log();
  const std::string none = syncError(options(h->tlsAddress(), "ca.pem"));
  EXPECT_NE(none.find("certificate required"), std::string::npos) << none;
  EXPECT_TRUE(eventually([&] {
    return h->log().find("peer did not return a certificate") != std::string::npos;
  })) << h->log();
  const std::string rogue = syncError(options(h->tlsAddress(), "ca.pem", "rogue-client"));
  EXPECT_FALSE(rogue.empty());
  EXPECT_TRUE(eventually([&] {
    return h->log().find("certificate verify failed") != std::string::npos;
  })) << h->log();
  expectServes(*h, "ca.pem", "client");

  SatelliteOptions so;
  so.connection = options(h->tlsAddress(), "ca.pem", "client");
  SatOnThread s(so);
  s.start();
  EXPECT_TRUE(eventually([&] { return s.connected(); })) << h->log();
}

}  // namespace
}  // namespace skr::sat::test
