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
  for (const char* bad : {"", "local:", "udp:x", "serial:", "serial:ttyUSB0", "serial:/dev/x@",
                          "serial:/dev/x@9k", "tcp:", "tcp:host:", "tcp:host:0", "tcp:host:70000",
                          "tcp:host:9x", "tcp:[::1", "tls:", "tls:host:0", "ssl:host"}) {
    auto r = Address::parse(bad);
    EXPECT_FALSE(r) << bad;
    if (!r) {
      EXPECT_EQ(r.error().code, Errc::invalid_argument);
    }
  }
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
