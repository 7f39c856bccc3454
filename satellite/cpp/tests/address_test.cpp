// SPDX-License-Identifier: Apache-2.0
// ROBOT_ADDRESS parsing, the environment, and the synchronous connection's errors.
#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

TEST(AddressTest, ParsesLocalAndTcp) {
  auto local = Address::parse("local:/tmp/Robot");
  ASSERT_TRUE(local);
  EXPECT_EQ(local->kind, Address::Kind::local);
  EXPECT_EQ(local->path, "/tmp/Robot");
  auto tcp = Address::parse("tcp:robot.local");
  ASSERT_TRUE(tcp);
  EXPECT_EQ(tcp->kind, Address::Kind::tcp);
  EXPECT_EQ(tcp->host, "robot.local");
  EXPECT_EQ(tcp->port, 9000);
  auto port = Address::parse("tcp:10.0.0.2:9100");
  ASSERT_TRUE(port);
  EXPECT_EQ(port->host, "10.0.0.2");
  EXPECT_EQ(port->port, 9100);
  auto v6 = Address::parse("tcp:[::1]:9001");
  ASSERT_TRUE(v6);
  EXPECT_EQ(v6->host, "::1");
  EXPECT_EQ(v6->port, 9001);
  EXPECT_EQ(v6->toString(), "tcp:[::1]:9001");
  EXPECT_EQ(port->toString(), "tcp:10.0.0.2:9100");
  auto tls = Address::parse("tls:robot.local:9443");
  ASSERT_TRUE(tls);
  EXPECT_EQ(tls->kind, Address::Kind::tls);
  EXPECT_EQ(tls->host, "robot.local");
  EXPECT_EQ(tls->port, 9443);
  EXPECT_EQ(tls->toString(), "tls:robot.local:9443");
  auto tls6 = Address::parse("tls:[::1]");
  ASSERT_TRUE(tls6);
  EXPECT_EQ(tls6->port, 9000);
  EXPECT_EQ(tls6->toString(), "tls:[::1]:9000");
  auto serial = Address::parse("serial:/dev/ttyUSB0@1000000");
  ASSERT_TRUE(serial);
  EXPECT_EQ(serial->kind, Address::Kind::serial);
  EXPECT_EQ(serial->path, "/dev/ttyUSB0");
  EXPECT_EQ(serial->baud, 1000000u);
  EXPECT_EQ(serial->toString(), "serial:/dev/ttyUSB0@1000000");
  EXPECT_EQ(Address::parse("serial:/dev/ttyACM0")->baud, 115200u);
  for (const char* bad : {"", "local:", "serial:", "serial:ttyUSB0", "serial:/dev/x@",
                          "serial:/dev/x@9k", "tcp:", "tcp:host:", "tcp:host:0", "tcp:host:70000",
                          "tcp:host:9x", "tcp:[::1", "tls:", "tls:host:0", "ssl:host", "ws:host"}) {
    auto r = Address::parse(bad);
    EXPECT_FALSE(r) << bad;
    if (!r) {
      EXPECT_EQ(r.error().code, Errc::invalid_argument);
    }
  }
}

TEST(AddressTest, ParsesUdp) {
  auto udp = Address::parse("udp:robot.local");
  ASSERT_TRUE(udp) << udp.error().message;
  EXPECT_EQ(udp->kind, Address::Kind::udp);
  EXPECT_EQ(udp->host, "robot.local");
  EXPECT_EQ(udp->port, 9001) << "server.udp's default port";
  EXPECT_EQ(udp->toString(), "udp:robot.local:9001");
  EXPECT_FALSE(udp->isNetwork()) << "no password crosses: the session opens with a key";
  auto port = Address::parse("udp:192.168.1.10:9100");
  ASSERT_TRUE(port);
  EXPECT_EQ(port->host, "192.168.1.10");
  EXPECT_EQ(port->port, 9100);
  EXPECT_EQ(port->toString(), "udp:192.168.1.10:9100");
  auto v6 = Address::parse("udp:[fd00::20]");
  ASSERT_TRUE(v6);
  EXPECT_EQ(v6->host, "fd00::20");
  EXPECT_EQ(v6->toString(), "udp:[fd00::20]:9001");
  EXPECT_EQ(Address::parse(v6->toString())->host, "fd00::20");
  for (const char* bad : {"udp:", "udp:host:", "udp:host:0", "udp:host:65536", "udp:[::1",
                          "udp:[::1]x", "udp::9001"}) {
    auto r = Address::parse(bad);
    EXPECT_FALSE(r) << bad;
    if (!r) {
      EXPECT_NE(r.error().message.find("udp:host[:port]"), std::string::npos);
    }
  }
}

TEST(AddressTest, UdpKeyFromTheEnvironment) {
  ::unsetenv("ROBOT_UDP_KEY_FILE");
  ::setenv("ROBOT_UDP_KEY", " 00112233445566778899aabbccddeeFF\n", 1);
  auto o = ConnectOptions::fromEnvironment("x");
  ASSERT_TRUE(o) << o.error().message;
  ASSERT_TRUE(o->udp_key);
  EXPECT_EQ((*o->udp_key)[0], 0x00);
  EXPECT_EQ((*o->udp_key)[1], 0x11);
  EXPECT_EQ((*o->udp_key)[15], 0xFF);
  for (const char* bad :
       {"0011", "00112233445566778899aabbccddeeffaa", "g0112233445566778899aabbccddeeff"}) {
    ::setenv("ROBOT_UDP_KEY", bad, 1);
    auto r = ConnectOptions::fromEnvironment("x");
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().code, Errc::invalid_argument);
    EXPECT_NE(r.error().message.find("ROBOT_UDP_KEY: a UDP key is 32 hex digits"),
              std::string::npos)
        << r.error().message;
    EXPECT_EQ(r.error().message.find(bad), std::string::npos) << "the key is not repeated";
  }
  ::unsetenv("ROBOT_UDP_KEY");
  TempDir dir;
  const fs::path file = dir.path() / "board.key";
  std::ofstream(file) << "ffeeddccbbaa99887766554433221100\n";
  ::setenv("ROBOT_UDP_KEY_FILE", file.c_str(), 1);
  auto f = ConnectOptions::fromEnvironment("x");
  ASSERT_TRUE(f) << f.error().message;
  ASSERT_TRUE(f->udp_key);
  EXPECT_EQ((*f->udp_key)[0], 0xff);
  ::setenv("ROBOT_UDP_KEY_FILE", (dir.path() / "missing.key").c_str(), 1);
  auto missing = ConnectOptions::fromEnvironment("x");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::not_found);
  EXPECT_NE(missing.error().message.find("missing.key"), std::string::npos);
  ::unsetenv("ROBOT_UDP_KEY_FILE");
  auto none = ConnectOptions::fromEnvironment("x");
  ASSERT_TRUE(none);
  EXPECT_FALSE(none->udp_key);
}

TEST(AddressTest, EnvironmentAndDefaults) {
  ::unsetenv("ROBOT_ADDRESS");
  ::unsetenv("ROBOT_USER");
  ::unsetenv("ROBOT_PASSWORD");
  auto d = ConnectOptions::fromEnvironment("x");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->address.toString(), std::string(kDefaultAddress));
  EXPECT_EQ(d->user, "guest");
  EXPECT_EQ(d->password, "password");
  ::setenv("ROBOT_ADDRESS", "tcp:hub", 1);
  ::setenv("ROBOT_USER", "alice", 1);
  ::setenv("ROBOT_PASSWORD", "s3cret", 1);
  auto e = ConnectOptions::fromEnvironment();
  ASSERT_TRUE(e);
  EXPECT_EQ(e->address.toString(), "tcp:hub:9000");
  EXPECT_EQ(e->user, "alice");
  EXPECT_EQ(e->password, "s3cret");
  EXPECT_FALSE(e->client_name.empty()) << "defaults to the program's name";
  ::setenv("ROBOT_ADDRESS", "nowhere", 1);
  EXPECT_FALSE(ConnectOptions::fromEnvironment());
  ::unsetenv("ROBOT_ADDRESS");
  ::unsetenv("ROBOT_USER");
  ::unsetenv("ROBOT_PASSWORD");
}

class SyncClientTest : public SatTest {};

TEST_F(SyncClientTest, NoHubWrongPasswordAndRequests) {
  auto o = options("sync").connection;
  auto none = SyncClient::connect(o);
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, Errc::io_error);
  EXPECT_NE(none.error().message.find("no hub at " + address() + ": is skrobot running?"),
            std::string::npos)
      << none.error().message;
  startHub();
  o.password = "wrong";
  auto refused = SyncClient::connect(o);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, Errc::auth_failed);
  o.password = "password";
  auto c = SyncClient::connect(o);
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->login().user, "guest");
  EXPECT_TRUE(c->ping());
  EXPECT_TRUE(c->set("answer", 42));
  auto v = c->get("answer");
  ASSERT_TRUE(v);
  EXPECT_EQ(*v, flow::Variant(42));
  auto missing = c->get("nope");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::not_found);
  EXPECT_EQ(c->lastError(), flow::ErrorCode::not_found);
  EXPECT_TRUE(c->isOpen()) << "a refusal keeps the connection";
  auto udp = o;
  udp.address = Address::parse("udp:127.0.0.1").value();
  auto over_udp = SyncClient::connect(udp);
  ASSERT_FALSE(over_udp);
  EXPECT_EQ(over_udp.error().code, Errc::unsupported);
  EXPECT_NE(over_udp.error().message.find("a udp: address carries one session, the flow"),
            std::string::npos)
      << over_udp.error().message;
  auto ch = c->channel("guest.nothing");
  ASSERT_FALSE(ch);
  EXPECT_EQ(ch.error().code, Errc::not_found);
  auto list = c->channels();
  ASSERT_TRUE(list);
  for (const auto& ch : *list)
    EXPECT_TRUE(ch.name.starts_with("hub.")) << ch.name;  // the hub's own
  auto dbs = c->databases();
  ASSERT_TRUE(dbs);
  EXPECT_NE(std::find(dbs->begin(), dbs->end(), "guest"), dbs->end());
}

}  // namespace
}  // namespace skr::sat::test
