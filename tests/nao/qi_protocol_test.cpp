// SPDX-License-Identifier: Apache-2.0
// The qi codec (signatures, values, message framing) and a full client session against
// QiTestServer: authentication on every connection, service look-up, metaObject, calls with
// arguments and their replies, services of a second session at its own endpoint, an error reply,
// oversized and malformed messages, a dropped connection and a lost second session.
#include "qi_client.h"
#include "qi_test_server.h"

#include <gtest/gtest.h>

namespace skr::nao::qi {
namespace {

TEST(QiSignature, ParsesNestedTypesAndAnnotations) {
  auto t = parseSignature(kMetaObjectSignature);
  ASSERT_TRUE(t) << t.error().message;
  EXPECT_EQ(t->kind, '(');
  EXPECT_EQ(t->name, "MetaObject");
  ASSERT_EQ(t->items.size(), 4u);
  EXPECT_EQ(t->items[0].kind, '{');
  EXPECT_EQ(t->items[0].items[1].name, "MetaMethod");
  EXPECT_EQ(toString(t.value()), kMetaObjectSignature);
  EXPECT_EQ(toString(parseSignature("{sm}").value()), "{sm}");
  for (const char* bad : {"", "[s", "{s}", "(s", "q", "ss", "(s)<A,b", "(s)<A b>", "[]"}) {
    EXPECT_FALSE(parseSignature(bad)) << bad;
  }
  EXPECT_FALSE(parseSignature(std::string(40, '[') + "s" + std::string(40, ']')));  // depth
}

TEST(QiValue, RoundTripsEveryKind) {
  const Value v = Value::tuple(
      {Value::boolean(true), Value::integer(-5, 'c'), Value::integer(65000, 'W'),
       Value::integer(-7), Value::integer(4000000000LL, 'I'), Value::integer(-1LL << 40, 'l'),
       Value::real(0.5), Value::real(1e300, 'd'), Value::string("héllo"),
       Value::strings({"a", "b"}),
       Value::map({{Value::string("k"), Value::list({Value::integer(1), Value::string("x")})}})});
  const char* sig = "(bcWiIlfds[s]{sm})";
  auto bytes = encode(sig, v);
  ASSERT_TRUE(bytes) << bytes.error().message;
  std::size_t used = 0;
  auto back = decode(sig, bytes.value(), &used);
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(used, bytes->size());
  EXPECT_EQ(back.value(), v);
  // The dynamic list of mixed items is sent as "[m]"; a uniform one as "[s]".
  EXPECT_EQ(toString(v.items()[10].naturalType()), "{s[m]}");
  EXPECT_EQ(toString(Value::strings({"a"}).naturalType()), "[s]");
}

TEST(QiValue, WireFormatIsLittleEndianWithLengthPrefixes) {
  EXPECT_EQ(encode("s", Value::string("ab")).value(), std::string("\x02\0\0\0ab", 6));
  EXPECT_EQ(encode("m", Value::integer(1)).value(), std::string("\x01\0\0\0i\x01\0\0\0", 9));
  EXPECT_EQ(encode("[b]", Value::list({Value::boolean(true)})).value(),
            std::string("\x01\0\0\0\x01", 5));
}

TEST(QiValue, RefusesShortCountsAndConversionsThatDoNotFit) {
  // A list announcing 2^31 strings in 8 bytes is refused before any allocation.
  EXPECT_FALSE(decode("[s]", std::string("\0\0\0\x80\0\0\0\0", 8)));
  EXPECT_FALSE(decode("s", std::string("\x05\0\0\0ab", 6)));
  EXPECT_FALSE(decode("[()]", std::string("\x05\0\0\0", 4)));  // zero-size elements
  EXPECT_FALSE(decode("m", std::string("\x01\0\0\0q", 5)));    // unknown dynamic type
  std::string deep;
  for (int i = 0; i < 40; ++i) deep += std::string("\x01\0\0\0m", 5);
  EXPECT_FALSE(decode("m", deep));  // nesting limit
  // 300000 one-byte booleans would take ~60 MB as values: refused by the value budget.
  std::string many("\xe0\x93\x04\0", 4);
  many.append(300000, '\1');
  auto budget = decode("[b]", many);
  ASSERT_FALSE(budget);
  EXPECT_NE(budget.error().message.find("values"), std::string::npos);
  EXPECT_FALSE(encode("i", Value::integer(1LL << 40)));
  EXPECT_FALSE(encode("I", Value::integer(-1)));
  EXPECT_FALSE(encode("s", Value::integer(1)));
  EXPECT_FALSE(encode("(ss)", Value::tuple({Value::string("a")})));
  EXPECT_TRUE(encode("d", Value::integer(3)));  // integers widen to floats
}

TEST(QiMessage, FramesHeaderAndPayloadAndRefusesBadHeaders) {
  Header h;
  h.id = 7;
  h.type = MsgType::call;
  h.service = 1;
  h.object = 1;
  h.action = 100;
  const std::string bytes = encodeMessage(h, "abc");
  ASSERT_EQ(bytes.size(), kHeaderSize + 3);
  EXPECT_EQ(bytes.substr(0, 4), "\x42\xde\xad\x42");  // magic, big-endian
  MessageFramer f;
  f.append(bytes.substr(0, 10));
  auto none = f.next();
  ASSERT_TRUE(none);
  EXPECT_FALSE(none.value());
  f.append(bytes.substr(10) + bytes);
  for (int i = 0; i < 2; ++i) {
    auto m = f.next();
    ASSERT_TRUE(m && m.value());
    EXPECT_EQ(m.value()->header.id, 7u);
    EXPECT_EQ(m.value()->header.action, 100u);
    EXPECT_EQ(m.value()->payload, "abc");
  }

  MessageFramer small(100);
  std::string big = encodeMessage(h, std::string(101, 'x'));
  small.append(big.substr(0, kHeaderSize));  // refused from the header alone
  auto r = small.next();
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("exceeds the limit"), std::string::npos);

  std::string bad = bytes;
  bad[0] = 0x43;
  MessageFramer g;
  g.append(bad);
  EXPECT_FALSE(g.next());
  bad = bytes;
  bad[14] = 42;  // unknown type
  MessageFramer k;
  k.append(bad);
  EXPECT_FALSE(k.next());
}

class QiSession : public ::testing::Test {
 protected:
  ClientOptions options() {
    ClientOptions o;
    o.port = server_.port();
    o.lookup_timeout_ms = 2000;
    return o;
  }
  test::QiTestServer server_;
  QiClient client_;
};

TEST_F(QiSession, AuthenticatesLooksUpAndCallsWithArguments) {
  ASSERT_TRUE(client_.connect(options()));
  EXPECT_EQ(server_.authentications(), 1);

  auto info = client_.serviceInfo("ALMotion");
  ASSERT_TRUE(info) << info.error().message;
  EXPECT_EQ(info->service_id, 11u);
  EXPECT_EQ(info->endpoints.at(0), "tcp://127.0.0.1:" + std::to_string(server_.port()));
  auto meta = client_.metaObject(11, kMainObject);
  ASSERT_TRUE(meta) << meta.error().message;
  const MetaMethod* set = meta->resolve(
      "setAngles", {Value::strings({"HeadYaw"}), Value::reals({0.5}), Value::real(0.2)});
  ASSERT_NE(set, nullptr);
  EXPECT_EQ(set->uid, 100u);
  EXPECT_EQ(set->parameters_signature, "(mmf)");
  // Overloads are told apart by their arguments.
  EXPECT_EQ(meta->resolve("moveToward", {Value::real(1), Value::real(0), Value::real(0)})->uid,
            101u);

  auto ok = client_.callSync(
      "ALMotion", "setAngles",
      {Value::strings({"HeadYaw", "HeadPitch"}), Value::reals({0.5, -0.25}), Value::real(0.2)},
      2000);
  ASSERT_TRUE(ok) << ok.error().message;
  auto reached = client_.callSync("ALRobotPosture", "goToPosture",
                                  {Value::string("Stand"), Value::real(0.5)}, 2000);
  ASSERT_TRUE(reached);
  EXPECT_TRUE(reached->asBool());
  auto posture = client_.callSync("ALRobotPosture", "getPosture", {}, 2000);
  ASSERT_TRUE(posture);
  EXPECT_EQ(posture->asString(), "Stand");
  auto angles = client_.callSync(
      "ALMotion", "getAngles", {Value::strings({"HeadYaw", "LHand"}), Value::boolean(true)}, 2000);
  ASSERT_TRUE(angles);
  ASSERT_EQ(angles->items().size(), 2u);
  EXPECT_FLOAT_EQ(static_cast<float>(angles->items()[1].asDouble()), 0.25f);

  const auto calls = server_.calls();
  ASSERT_EQ(calls.size(), 4u);
  EXPECT_EQ(calls[0].service, "ALMotion");
  EXPECT_EQ(calls[0].method, "setAngles");
  EXPECT_EQ(calls[0].args.items()[0], Value::strings({"HeadYaw", "HeadPitch"}));
  EXPECT_FLOAT_EQ(static_cast<float>(calls[0].args.items()[1].items()[1].asDouble()), -0.25f);
  EXPECT_FLOAT_EQ(static_cast<float>(calls[0].args.items()[2].asDouble()), 0.2f);
  EXPECT_EQ(calls[1].method, "goToPosture");
  EXPECT_EQ(calls[1].args.items()[0].asString(), "Stand");
}

TEST_F(QiSession, ErrorRepliesAndUnknownNamesAreErrors) {
  ASSERT_TRUE(client_.connect(options()));
  auto said = client_.callSync("ALTextToSpeech", "say", {Value::string("fail")}, 2000);
  ASSERT_FALSE(said);
  EXPECT_EQ(said.error().code, Errc::remote);
  EXPECT_EQ(said.error().message, "ALTextToSpeech::say: speech engine failure");
  auto missing = client_.callSync("ALNoSuchService", "x", {}, 2000);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::not_found);
  EXPECT_NE(missing.error().message.find("Cannot find service"), std::string::npos);
  auto wrong = client_.callSync("ALTextToSpeech", "say", {Value::integer(3)}, 2000);
  ASSERT_FALSE(wrong);
  EXPECT_EQ(wrong.error().code, Errc::not_found);
  // The connection survives all three.
  EXPECT_TRUE(client_.callSync("ALTextToSpeech", "say", {Value::string("hi")}, 2000));
}

TEST_F(QiSession, DynamicPayloadRepliesAreDecoded) {
  ASSERT_TRUE(client_.connect(options()));
  ASSERT_TRUE(client_.resolve("ALMemory"));
  server_.setDynamicReplies(true);
  auto v = client_.callSync("ALMemory", "getListData", {Value::strings({"a", "b"})}, 2000);
  ASSERT_TRUE(v) << v.error().message;
  ASSERT_EQ(v->items().size(), 2u);
  EXPECT_FLOAT_EQ(static_cast<float>(v->items()[0].asDouble()), 0.75f);
}

TEST_F(QiSession, DroppedConnectionFailsPendingCallsAndLaterOnes) {
  ASSERT_TRUE(client_.connect(options()));
  ASSERT_TRUE(client_.resolve("ALTextToSpeech"));
  server_.setAccepting(false);
  server_.dropConnection();
  std::optional<Result<Value>> answer;
  // The call may be written before the server notices; either way it must end with an error.
  auto sent = client_.call("ALTextToSpeech", "say", {Value::string("hello")}, 2000,
                           [&](Result<Value> v) { answer.emplace(std::move(v)); });
  for (int i = 0; i < 100 && client_.connected(); ++i) (void)client_.pump(20);
  EXPECT_FALSE(client_.connected());
  if (sent) {
    ASSERT_TRUE(answer);
    ASSERT_FALSE(*answer);
    EXPECT_EQ(answer->error().code, Errc::closed);
  }
  auto later = client_.callSync("ALTextToSpeech", "say", {Value::string("x")}, 500);
  ASSERT_FALSE(later);
  EXPECT_EQ(later.error().code, Errc::closed);
  // Reconnecting is refused while the robot is away, then works again.
  EXPECT_FALSE(client_.connect(options()));
  server_.setAccepting(true);
  ASSERT_TRUE(client_.connect(options()));
  EXPECT_TRUE(client_.callSync("ALTextToSpeech", "say", {Value::string("back")}, 2000));
}

TEST_F(QiSession, OversizedAndMalformedRepliesCloseTheConnection) {
  ClientOptions o = options();
  o.max_payload = 4096;
  ASSERT_TRUE(client_.connect(o));
  ASSERT_TRUE(client_.resolve("ALTextToSpeech"));
  Header h;
  h.type = MsgType::reply;
  h.id = 1000;
  std::string huge = encodeMessage(h, "");
  huge[8] = 0;
  huge[9] = 0;
  huge[10] = 0;
  huge[11] = 0x10;  // announces 256 MiB
  server_.sendRawNext(huge);
  auto r = client_.callSync("ALTextToSpeech", "say", {Value::string("x")}, 2000);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::closed);
  EXPECT_NE(r.error().message.find("exceeds the limit"), std::string::npos);
  // It came over the second session's connection: only that one is closed, with its services.
  EXPECT_TRUE(client_.connected());
  EXPECT_EQ(client_.connections(), 1u);
  EXPECT_EQ(client_.takeLost().count("ALTextToSpeech"), 1u);

  // A reply whose payload does not match the method's signature also closes its connection,
  // here the directory's: all of them.
  ASSERT_TRUE(client_.connect(o));
  ASSERT_TRUE(client_.resolve("ALRobotPosture"));
  server_.corruptNextReply();
  r = client_.callSync("ALRobotPosture", "getPosture", {}, 2000);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::protocol_error);
  EXPECT_NE(r.error().message.find("QI-PROTOCOL"), std::string::npos);
  EXPECT_FALSE(client_.connected());

  ASSERT_TRUE(client_.connect(o));
  ASSERT_TRUE(client_.resolve("ALTextToSpeech"));
  server_.sendRawNext("GET / HTTP/1.1\r\nHost: nao.local\r\n\r\n");
  r = client_.callSync("ALTextToSpeech", "say", {Value::string("x")}, 2000);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("bad magic"), std::string::npos);
}

TEST_F(QiSession, LooksUpWithSevenFieldsAndWithSix) {
  ASSERT_TRUE(client_.connect(options()));
  auto info = client_.serviceInfo("ALMotion");
  ASSERT_TRUE(info) << info.error().message;
  EXPECT_EQ(info->object_uid, test::QiTestServer::kObjectUid);  // libqi 4's seventh field
  EXPECT_EQ(info->process_id, 42u);
  EXPECT_EQ(info->session_id, "session");
  server_.setSixFieldLookups(true);  // libqi before 4
  info = client_.serviceInfo("ALMemory");
  ASSERT_TRUE(info) << info.error().message;
  EXPECT_EQ(info->service_id, 13u);
  EXPECT_EQ(info->object_uid, "");
  EXPECT_TRUE(client_.callSync("ALMemory", "getData", {Value::string("k")}, 2000));
}

TEST_F(QiSession, RepliesNotReadToTheEndAreRefused) {
  ASSERT_TRUE(client_.connect(options()));
  ASSERT_TRUE(client_.resolve("ALRobotPosture"));
  server_.appendToNextReply(std::string("\x01\0\0\0", 4));
  auto r = client_.callSync("ALRobotPosture", "getPosture", {}, 2000);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::protocol_error);
  EXPECT_NE(r.error().message.find("4 bytes left"), std::string::npos) << r.error().message;
  EXPECT_FALSE(client_.connected());

  // A look-up answer with more than the seven fields is refused too.
  ASSERT_TRUE(client_.connect(options()));
  server_.appendToNextReply("xyz");
  auto info = client_.serviceInfo("ALMotion");
  ASSERT_FALSE(info);
  EXPECT_EQ(info.error().code, Errc::protocol_error);
  EXPECT_FALSE(client_.connected());
  EXPECT_FALSE(decode("s", std::string("\x01\0\0\0ab", 6)));
  std::size_t used = 0;
  EXPECT_TRUE(decode("s", std::string("\x01\0\0\0ab", 6), &used));
  EXPECT_EQ(used, 5u);
}

// ALTextToSpeech and ALLeds are hosted by a second session with its own endpoint: another
// process, or (as in the libqi 4.0.5 server this was tried against) a second session of the
// directory's own process, whose look-ups then name the same process as the directory's. Either
// way their calls must go to their own endpoint: the directory's server does not host them and
// answers "The call request could not be handled.".
class QiSecondSession : public QiSession, public ::testing::WithParamInterface<std::uint32_t> {};

TEST_P(QiSecondSession, ServicesOfASecondSessionAreCalledAtItsOwnEndpoint) {
  server_.setSideProcessId(GetParam());
  ASSERT_TRUE(client_.connect(options()));
  auto info = client_.serviceInfo("ALLeds");
  ASSERT_TRUE(info) << info.error().message;
  ASSERT_EQ(info->endpoints.size(), 1u);
  EXPECT_EQ(info->endpoints[0], "tcp://127.0.0.1:" + std::to_string(server_.sidePort()));
  EXPECT_EQ(info->process_id, GetParam());

  auto ok =
      client_.callSync("ALLeds", "fadeRGB",
                       {Value::string("FaceLeds"), Value::integer(0xff0000), Value::real(0)}, 2000);
  ASSERT_TRUE(ok) << ok.error().message;
  ASSERT_TRUE(client_.callSync("ALTextToSpeech", "say", {Value::string("hi")}, 2000));
  ASSERT_TRUE(client_.callSync("ALMotion", "stopMove", {}, 2000));
  const auto calls = server_.calls();
  ASSERT_EQ(calls.size(), 3u);
  EXPECT_EQ(calls[0].method, "fadeRGB");
  EXPECT_EQ(calls[0].endpoint, 1);
  EXPECT_EQ(calls[1].endpoint, 1);
  EXPECT_EQ(calls[2].endpoint, 0);
  // One connection to the second session, shared by its two services, authenticated too.
  EXPECT_EQ(client_.connections(), 2u);
  EXPECT_EQ(server_.sideConnections(), 1);
  EXPECT_EQ(server_.authentications(), 2);
  EXPECT_EQ(server_.refusedUnauthenticated(), 0);
  EXPECT_EQ(client_.endpointOf("ALLeds"), "127.0.0.1:" + std::to_string(server_.sidePort()));
  EXPECT_EQ(client_.endpointOf("ALMotion"), "127.0.0.1:" + std::to_string(server_.port()));

  // Losing every connection (the robot went away) closes the client.
  server_.dropConnection();
  for (int i = 0; i < 100 && client_.connected(); ++i) (void)client_.pump(20);
  EXPECT_FALSE(client_.connected());
  EXPECT_EQ(client_.connections(), 0u);
}

INSTANTIATE_TEST_SUITE_P(SideSession, QiSecondSession,
                         ::testing::Values(43u, test::kDirectoryProcess),
                         [](const ::testing::TestParamInfo<std::uint32_t>& p) {
                           return p.param == test::kDirectoryProcess
                                      ? std::string("InTheDirectorysProcess")
                                      : std::string("InAnotherProcess");
                         });

// The test server stands in for libqi 4.0.5 here: each connection, on each endpoint, must make
// the capability exchange before anything else.
TEST_F(QiSession, EveryEndpointRefusesCallsBeforeTheCapabilityExchange) {
  for (const std::uint16_t port : {server_.port(), server_.sidePort()}) {
    const std::uint32_t service = port == server_.port() ? 11 : 14;  // ALMotion, ALLeds
    ClientOptions o = options();
    o.port = port;
    o.authenticate = false;
    QiClient bare;
    ASSERT_TRUE(bare.connect(o));
    auto meta = bare.metaObject(service, kMainObject);
    ASSERT_FALSE(meta) << port;
    EXPECT_EQ(meta.error().message, "The call request could not be handled.");
    o.authenticate = true;
    QiClient authenticated;
    ASSERT_TRUE(authenticated.connect(o));
    meta = authenticated.metaObject(service, kMainObject);
    EXPECT_TRUE(meta) << port << ": " << meta.error().message;
  }
  EXPECT_EQ(server_.authentications(), 2);
}

// The second session's process goes away while the robot stays: only its services are lost,
// and they are reached again, over a new authenticated connection, once it is back.
TEST_F(QiSession, LosingAnotherEndpointLosesOnlyItsServices) {
  ASSERT_TRUE(client_.connect(options()));
  ASSERT_TRUE(client_.callSync(
      "ALLeds", "fadeRGB", {Value::string("FaceLeds"), Value::integer(1), Value::real(0)}, 2000));
  ASSERT_TRUE(client_.resolve("ALTextToSpeech"));
  ASSERT_TRUE(client_.resolve("ALMotion"));
  ASSERT_EQ(client_.connections(), 2u);

  server_.setAccepting(false, 1);
  server_.dropConnection(1);
  std::map<std::string, std::string> lost;
  for (int i = 0; i < 100 && lost.size() < 2; ++i) {
    ASSERT_TRUE(client_.pump(20));
    lost.merge(client_.takeLost());
  }
  ASSERT_EQ(lost.size(), 2u);
  EXPECT_NE(lost["ALLeds"].find(std::to_string(server_.sidePort())), std::string::npos)
      << lost["ALLeds"];
  EXPECT_TRUE(lost.count("ALTextToSpeech"));
  EXPECT_TRUE(client_.connected());
  EXPECT_EQ(client_.connections(), 1u);
  EXPECT_EQ(client_.endpointOf("ALLeds"), "");
  EXPECT_TRUE(client_.callSync("ALMotion", "stopMove", {}, 2000));
  EXPECT_FALSE(client_.resolve("ALLeds"));  // its endpoint closes every new connection
  EXPECT_TRUE(client_.connected());

  server_.setAccepting(true, 1);
  auto ok = client_.callSync("ALLeds", "fadeRGB",
                             {Value::string("FaceLeds"), Value::integer(2), Value::real(0)}, 2000);
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(client_.connections(), 2u);
  EXPECT_EQ(server_.authentications(), 3);
  EXPECT_EQ(server_.refusedUnauthenticated(), 0);
}

TEST_F(QiSession, WithoutTheCapabilityMapNaoqi25RefusesEveryCall) {
  ClientOptions o = options();
  o.authenticate = false;
  ASSERT_TRUE(client_.connect(o));  // TCP only; the directory's own look-up is refused
  auto r = client_.resolve("ALMotion");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("The call request could not be handled"), std::string::npos);
  EXPECT_NE(r.error().message.find("\"authenticate\" is off"), std::string::npos)
      << r.error().message;
  EXPECT_GE(server_.refusedUnauthenticated(), 2);
  EXPECT_EQ(server_.authentications(), 0);
}

TEST(QiEndpoint, ParsesTcpUrlsAndRefusesTheRest) {
  auto e = parseEndpoint("tcp://192.168.1.12:9559");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "192.168.1.12");
  EXPECT_EQ(e->port, 9559);
  e = parseEndpoint("tcp://[fe80::1]:40000");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->host, "fe80::1");
  EXPECT_EQ(e->text(), "[fe80::1]:40000");
  auto tls = parseEndpoint("tcps://10.0.0.2:9503");
  ASSERT_FALSE(tls);
  EXPECT_EQ(tls.error().code, Errc::unsupported);
  for (const char* bad : {"", "192.168.1.12:9559", "tcp://host", "tcp://host:0", "tcp://h:70000",
                          "tcp://h:12x", "tcp://[::1]9559"}) {
    EXPECT_FALSE(parseEndpoint(bad)) << bad;
  }
  EXPECT_TRUE(isLoopback("127.0.0.1"));
  EXPECT_TRUE(isLoopback("::1"));
  EXPECT_FALSE(isLoopback("192.168.1.12"));
}

TEST(QiClientConnect, ReportsARefusedConnection) {
  std::uint16_t port = 0;
  { port = test::QiTestServer().port(); }  // a port nobody listens on now
  QiClient c;
  ClientOptions o;
  o.port = port;
  o.connect_timeout_ms = 500;
  auto r = c.connect(o);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::io_error);
}

}  // namespace
}  // namespace skr::nao::qi
