// SPDX-License-Identifier: Apache-2.0
// The nao-bridge module in a hub: its service channel with the simulated Nao, its state streams,
// command queues, and the naoqi backend against QiTestServer (calls, connection loss, retry).
#include "log_capture.h"
#include "module_fixture.h"
#include "qi_test_server.h"

#include <sys/resource.h>

#include <chrono>
#include <thread>

namespace skr::test {
namespace {

using flow::Code;
using flow::Variant;
namespace msg = flow::msg;

Json::Value json(std::string_view text) {
  Json::Value v;
  Json::CharReaderBuilder b;
  std::string errors;
  std::istringstream in{std::string(text)};
  EXPECT_TRUE(Json::parseFromStream(b, in, &v, &errors)) << text;
  return v;
}

double cpuSeconds() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e6;
}

class NaoBridge : public ModuleFixture {
 protected:
  void SetUp() override { startHub(); }

  uint16_t channel(TestClient& sync, const std::string& name,
                   flow::msg::ChannelInfo* info = nullptr) {
    auto reply = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{name}));
    EXPECT_TRUE(reply) << name;
    if (!reply) return 0;
    if (info != nullptr) *info = reply->info;
    return reply->info.id;
  }
  // A command through the service channel; the answer as JSON.
  Json::Value command(TestClient& sync, const std::string& cmd, const std::string& value_json) {
    auto value = flow::variantFromJsonText(value_json);
    EXPECT_TRUE(value);
    auto reply = as<msg::ReplyValue>(sync.call(msg::ServiceCall{command_, 5000, cmd, value.value()},
                                               flow::ValueEncoding::binary));
    EXPECT_TRUE(reply) << cmd;
    return reply ? json(flow::variantToJsonText(reply->value)) : Json::Value();
  }
  // The next message on `chan` for which `pred` holds, within timeout_ms.
  template <class Pred>
  Json::Value waitData(TestClient& sat, uint16_t chan, Pred pred, int timeout_ms = 5000) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (std::chrono::steady_clock::now() < end) {
      auto d = as<msg::EvData>(sat.waitFor(Code::ev_data, 1000));
      if (!d || d->chan_id != chan) continue;
      Json::Value v = json(d->payload.bytes);
      if (pred(v)) return v;
    }
    ADD_FAILURE() << "no matching data on channel " << chan;
    return Json::Value();
  }

  uint16_t command_ = 0;
};

TEST_F(NaoBridge, SimulatedCommandsStateStreamsAndErrors) {
  ASSERT_TRUE(startModule("nao-bridge", R"({"backend":"simulated",
      "rates_hz":{"joints":25,"sonar":5,"battery":5,"posture":10,"fall":5}})",
                          false)
                  .empty());
  TestClient sync = syncClient();
  TestClient sat = flowClient();
  command_ = channel(sync, "nao-bridge.command");
  flow::msg::ChannelInfo joints_info;
  const uint16_t joints = channel(sync, "nao-bridge.joints", &joints_info);
  EXPECT_EQ(*joints_info.props.find("units"), Variant("rad"));
  const Variant* names = joints_info.props.find("names");
  ASSERT_NE(names, nullptr);
  EXPECT_EQ(flow::variantToJsonText(*names).find("\"HeadYaw\""), 1u);

  // Refusals are immediate and say why.
  Json::Value r = command(sync, "dance", "{}");
  EXPECT_FALSE(r["ok"].asBool());
  EXPECT_EQ(r["code"].asString(), "unknown_command");
  r = command(sync, "head", R"({"yaw":3.0})");
  EXPECT_EQ(r["code"].asString(), "out_of_range");
  EXPECT_NE(r["error"].asString().find("HeadYaw"), std::string::npos);
  r = command(sync, "head", R"({"yaw":0.5})");
  EXPECT_EQ(r["code"].asString(), "robot_error");  // resting: not stiff yet

  ASSERT_TRUE(command(sync, "wake", "{}")["ok"].asBool());
  ASSERT_TRUE(
      command(sync, "", R"({"cmd":"head","yaw":0.5,"pitch":-0.2,"speed":0.5})")["ok"].asBool());
  ASSERT_TRUE(sat.send(msg::Subscribe{1, joints}));
  Json::Value angles = waitData(sat, joints, [](const Json::Value& v) {
    return std::abs(v["angles"][0].asDouble() - 0.5) < 1e-6;
  });
  EXPECT_EQ(angles["angles"].size(), 26u);
  EXPECT_NEAR(angles["angles"][1].asDouble(), -0.2, 1e-6);

  const uint16_t posture = channel(sync, "nao-bridge.posture");
  ASSERT_TRUE(sat.send(msg::Subscribe{2, posture}));
  ASSERT_TRUE(command(sync, "posture", R"({"name":"Stand","speed":1})")["ok"].asBool());
  waitData(sat, posture, [](const Json::Value& v) { return v["posture"].asString() == "Stand"; });
  ASSERT_TRUE(command(sync, "walk", R"({"x":1})")["ok"].asBool());
  waitData(sat, posture, [](const Json::Value& v) { return v["odometry"]["x"].asDouble() > 0.05; });
  ASSERT_TRUE(command(sync, "stop", "{}")["ok"].asBool());

  const uint16_t battery = channel(sync, "nao-bridge.battery");
  ASSERT_TRUE(sat.send(msg::Subscribe{3, battery}));
  Json::Value b = waitData(sat, battery, [](const Json::Value& v) { return v.isMember("charge"); });
  EXPECT_GT(b["charge"].asDouble(), 0.9);
  EXPECT_LT(b["charge"].asDouble(), 1.0);

  // Status: connected, in the module's database.
  ASSERT_EQ(sync.call(msg::DbSelect{"nao-bridge"})->kind(), Code::reply_ok);
  auto status = as<msg::ReplyValue>(sync.call(msg::VarGet{"status"}));
  ASSERT_TRUE(status);
  EXPECT_EQ(*status->value.find("connected"), Variant(true));
}

TEST_F(NaoBridge, CommandQueuesRunInOrderAndReportResults) {
  TestClient sat = flowClient();
  const uint16_t queue = addChannel(sat, "naoq");
  ASSERT_TRUE(
      startModule("nao", R"({"backend":"simulated","queues":["guest.naoq"]})", false, "nao-bridge")
          .empty());
  TestClient sync = syncClient();
  const uint16_t results = channel(sync, "nao.results");
  ASSERT_TRUE(sat.send(msg::Subscribe{1, results}));
  ASSERT_TRUE(sat.waitFor(Code::ev_start_publish));  // the bridge subscribed to the queue
  for (const char* c : {R"({"cmd":"wake"})", R"({"cmd":"head","yaw":9})", R"({"cmd":"fly"})",
                        R"({"cmd":"say","text":"hello"})"}) {
    ASSERT_TRUE(sat.send(msg::Publish{queue, msg::Rest{c}}));
  }
  std::vector<Json::Value> got;
  while (got.size() < 4) {
    got.push_back(waitData(sat, results, [](const Json::Value&) { return true; }));
    if (got.back().isNull()) break;
  }
  ASSERT_EQ(got.size(), 4u);
  const char* codes[] = {nullptr, "out_of_range", "unknown_command", nullptr};
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(got[i]["seq"].asUInt64(), i + 1);
    EXPECT_EQ(got[i]["queue"].asString(), "guest.naoq");
    EXPECT_EQ(got[i]["ok"].asBool(), codes[i] == nullptr) << i;
    if (codes[i] != nullptr) {
      EXPECT_EQ(got[i]["code"].asString(), codes[i]);
    }
  }
}

TEST_F(NaoBridge, NaoqiBackendCallsTheRobotAndSurvivesConnectionLoss) {
  nao::test::QiTestServer robot;
  const std::string config = R"({"backend":"naoqi","host":"127.0.0.1","port":)" +
                             std::to_string(robot.port()) +
                             R"(,"reconnect_min_ms":50,"reconnect_max_ms":200,
                                "call_timeout_ms":1000,"rates_hz":{"posture":20}})";
  ASSERT_TRUE(startModule("nao", config, false, "nao-bridge").empty());
  TestClient sync = syncClient();
  TestClient sat = flowClient();
  command_ = channel(sync, "nao.command");
  const uint16_t status = channel(sync, "nao.status");
  ASSERT_TRUE(sat.send(msg::Subscribe{1, status}));
  waitData(sat, status, [](const Json::Value& v) { return v["connected"].asBool(); });

  ASSERT_TRUE(command(sync, "say", R"({"text":"hello"})")["ok"].asBool());
  ASSERT_TRUE(
      command(sync, "joints", R"({"names":["LShoulderPitch"],"angles":[0.5]})")["ok"].asBool());
  ASSERT_TRUE(command(sync, "walk", R"({"x":0.5,"theta":-0.25})")["ok"].asBool());
  ASSERT_TRUE(command(sync, "leds", R"({"group":"FaceLeds","rgb":"#ff0000"})")["ok"].asBool());
  Json::Value r = command(sync, "posture", R"({"name":"Sit"})");
  ASSERT_TRUE(r["ok"].asBool());
  r = command(sync, "say", R"({"text":"fail"})");
  EXPECT_EQ(r["code"].asString(), "robot_error");
  EXPECT_NE(r["error"].asString().find("speech engine failure"), std::string::npos);

  std::vector<nao::test::RecordedCall> calls;
  for (const auto& c : robot.calls()) {
    if (c.method != "getPosture") calls.push_back(c);  // the posture stream may poll meanwhile
  }
  ASSERT_EQ(calls.size(), 6u);
  EXPECT_EQ(calls[0].method, "say");
  EXPECT_EQ(calls[0].args.items()[0].asString(), "hello");
  EXPECT_EQ(calls[1].method, "setAngles");
  EXPECT_EQ(calls[1].args.items()[0], nao::qi::Value::strings({"LShoulderPitch"}));
  EXPECT_FLOAT_EQ(static_cast<float>(calls[1].args.items()[2].asDouble()), 0.2f);
  EXPECT_EQ(calls[2].method, "moveToward");
  EXPECT_FLOAT_EQ(static_cast<float>(calls[2].args.items()[2].asDouble()), -0.25f);
  EXPECT_EQ(calls[3].method, "fadeRGB");
  EXPECT_EQ(calls[3].args.items()[1].asInt(), 0xff0000);
  EXPECT_EQ(calls[3].endpoint, 1);  // ALLeds and ALTextToSpeech live "in another process"
  EXPECT_EQ(calls[0].endpoint, 1);
  EXPECT_EQ(calls[1].endpoint, 0);
  EXPECT_EQ(calls[4].method, "goToPosture");
  EXPECT_EQ(calls[4].args.items()[0].asString(), "Sit");

  const uint16_t posture = channel(sync, "nao.posture");
  ASSERT_TRUE(sat.send(msg::Subscribe{2, posture}));
  waitData(sat, posture, [](const Json::Value& v) { return v["posture"].asString() == "Sit"; });

  // The robot goes away: reported on the status channel, commands fail at once.
  robot.setAccepting(false);
  robot.dropConnection();
  Json::Value down =
      waitData(sat, status, [](const Json::Value& v) { return !v["connected"].asBool(); });
  EXPECT_FALSE(down["error"].asString().empty());
  const auto t0 = std::chrono::steady_clock::now();
  r = command(sync, "say", R"({"text":"anyone?"})");
  EXPECT_EQ(r["code"].asString(), "not_connected");
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500));

  // Retries back off: 50, 100, 200, 200... ms, so about 6 attempts in a second, not hundreds.
  // Waiting for the next attempt costs no CPU.
  const int before = robot.connections();
  const double cpu_before = cpuSeconds();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const int attempts = robot.connections() - before;
  EXPECT_GE(attempts, 3);
  EXPECT_LE(attempts, 12);
  EXPECT_LT(cpuSeconds() - cpu_before, 0.3);

  // It comes back: the bridge reconnects by itself.
  robot.setAccepting(true);
  waitData(sat, status, [](const Json::Value& v) { return v["connected"].asBool(); });
  EXPECT_TRUE(command(sync, "say", R"({"text":"back"})")["ok"].asBool());
  EXPECT_GE(robot.authentications(), 2);
}

// A robot lacking a service stays connected: the commands that need it fail at once, naming
// it, the others work, the status lists it, and it is looked for again with the backoff.
TEST_F(NaoBridge, AMissingServiceFailsOnlyTheCommandsThatNeedIt) {
  LogCapture log;
  nao::test::QiTestServer robot;
  robot.removeService("ALLeds");
  const std::string config = R"({"backend":"naoqi","host":"127.0.0.1","port":)" +
                             std::to_string(robot.port()) +
                             R"(,"reconnect_min_ms":50,"reconnect_max_ms":200,
                                "rates_hz":{"posture":20}})";
  ASSERT_TRUE(startModule("nao", config, false, "nao-bridge").empty());
  TestClient sync = syncClient();
  TestClient sat = flowClient();
  command_ = channel(sync, "nao.command");
  const uint16_t status = channel(sync, "nao.status");
  ASSERT_TRUE(sat.send(msg::Subscribe{1, status}));
  Json::Value up = waitData(sat, status, [](const Json::Value& v) {
    return v["connected"].asBool() && v["missing"].isMember("ALLeds");
  });
  EXPECT_EQ(up["missing"].size(), 1u) << up.toStyledString();
  EXPECT_NE(up["missing"]["ALLeds"].asString().find("Cannot find service 'ALLeds'"),
            std::string::npos)
      << up.toStyledString();
  EXPECT_GT(up["retry_in_ms"].asInt(), 0);

  Json::Value r = command(sync, "leds", R"({"group":"FaceLeds","rgb":"#00ff00"})");
  EXPECT_EQ(r["code"].asString(), "service_unavailable");
  EXPECT_NE(r["error"].asString().find("NAOqi service ALLeds unavailable"), std::string::npos)
      << r["error"].asString();
  EXPECT_TRUE(command(sync, "say", R"({"text":"hello"})")["ok"].asBool());
  EXPECT_TRUE(command(sync, "walk", R"({"x":0.5})")["ok"].asBool());
  const uint16_t posture = channel(sync, "nao.posture");
  ASSERT_TRUE(sat.send(msg::Subscribe{2, posture}));
  waitData(sat, posture, [](const Json::Value& v) { return v.isMember("posture"); });

  // It appears (its process started late): found by the next look, and its commands work.
  robot.restoreService("ALLeds");
  waitData(sat, status, [](const Json::Value& v) {
    return v["connected"].asBool() && v["missing"].empty() && v["retry_in_ms"].asInt() == 0;
  });
  EXPECT_TRUE(command(sync, "leds", R"({"group":"FaceLeds","rgb":"#00ff00"})")["ok"].asBool());
  int fades = 0;
  for (const auto& c : robot.calls()) fades += c.method == "fadeRGB" ? 1 : 0;
  EXPECT_EQ(fades, 1);

  bool missing_logged = false;
  bool found_logged = false;
  for (const auto& line : log.lines()) {
    missing_logged = missing_logged || (line.rfind("NAO-SERVICE-MISSING ", 0) == 0 &&
                                        line.find("ALLeds") != std::string::npos);
    found_logged = found_logged || line.rfind("NAO-SERVICE-FOUND ALLeds", 0) == 0;
    EXPECT_EQ(line.rfind("NAO-DISCONNECTED ", 0), std::string::npos) << line;
  }
  EXPECT_TRUE(missing_logged);
  EXPECT_TRUE(found_logged);
}

// ALTextToSpeech and ALLeds are a second session with its own endpoint, in the directory's own
// process (as in the libqi 4.0.5 server). That session goes away while the robot stays: only
// `say` and `leds` fail, naming their service, until it is back.
TEST_F(NaoBridge, AServiceWhoseSessionGoesAwayIsMissingUntilItIsBack) {
  nao::test::QiTestServer robot;
  robot.setSideProcessId(nao::test::kDirectoryProcess);
  const std::string config = R"({"backend":"naoqi","host":"127.0.0.1","port":)" +
                             std::to_string(robot.port()) +
                             R"(,"reconnect_min_ms":50,"reconnect_max_ms":200})";
  ASSERT_TRUE(startModule("nao", config, false, "nao-bridge").empty());
  TestClient sync = syncClient();
  TestClient sat = flowClient();
  command_ = channel(sync, "nao.command");
  const uint16_t status = channel(sync, "nao.status");
  ASSERT_TRUE(sat.send(msg::Subscribe{1, status}));
  Json::Value up =
      waitData(sat, status, [](const Json::Value& v) { return v["connected"].asBool(); });
  EXPECT_TRUE(up["missing"].empty()) << up.toStyledString();
  ASSERT_TRUE(command(sync, "leds", R"({"group":"FaceLeds","rgb":"#ff0000"})")["ok"].asBool());
  ASSERT_TRUE(command(sync, "say", R"({"text":"hello"})")["ok"].asBool());
  ASSERT_EQ(robot.calls().size(), 2u);
  EXPECT_EQ(robot.calls()[0].endpoint, 1);
  EXPECT_EQ(robot.calls()[1].endpoint, 1);

  robot.setAccepting(false, 1);
  robot.removeService("ALLeds");
  robot.removeService("ALTextToSpeech");
  robot.dropConnection(1);
  Json::Value down = waitData(sat, status, [](const Json::Value& v) {
    return v["missing"].isMember("ALLeds") && v["missing"].isMember("ALTextToSpeech");
  });
  EXPECT_TRUE(down["connected"].asBool());
  Json::Value r = command(sync, "say", R"({"text":"anyone?"})");
  EXPECT_EQ(r["code"].asString(), "service_unavailable");
  EXPECT_NE(r["error"].asString().find("ALTextToSpeech"), std::string::npos)
      << r["error"].asString();
  EXPECT_TRUE(command(sync, "stop", "{}")["ok"].asBool());

  robot.restoreService("ALLeds");
  robot.restoreService("ALTextToSpeech");
  robot.setAccepting(true, 1);
  waitData(sat, status,
           [](const Json::Value& v) { return v["connected"].asBool() && v["missing"].empty(); });
  EXPECT_TRUE(command(sync, "say", R"({"text":"back"})")["ok"].asBool());
  EXPECT_EQ(robot.calls().back().endpoint, 1);
}

TEST_F(NaoBridge, AuthenticateFalseIsWarnedAbout) {
  LogCapture log;
  nao::test::QiTestServer robot;
  const std::string config = R"({"backend":"naoqi","host":"127.0.0.1","port":)" +
                             std::to_string(robot.port()) + R"(,"authenticate":false})";
  ASSERT_TRUE(startModule("nao", config, false, "nao-bridge").empty());
  bool warned = false;
  for (const auto& line : log.lines()) {
    warned = warned || (line.rfind("NAO-CONFIG ", 0) == 0 &&
                        line.find("NAOqi 2.5 and later") != std::string::npos);
  }
  EXPECT_TRUE(warned);
  // And the test server, like NAOqi 2.5+, indeed refuses such a client.
  TestClient sync = syncClient();
  TestClient sat = flowClient();
  const uint16_t status = channel(sync, "nao.status");
  ASSERT_TRUE(sat.send(msg::Subscribe{1, status}));
  Json::Value down = waitData(sat, status, [](const Json::Value& v) {
    return v["error"].asString().find("could not be handled") != std::string::npos;
  });
  EXPECT_FALSE(down["connected"].asBool());
}

TEST_F(NaoBridge, RefusesABadConfig) {
  LogCapture log;
  // Declared keys: the host refuses them before init.
  for (const char* bad : {R"({"backend":"python2"})", R"({"backend":"naoqi","port":70000})",
                          R"({"authenticate":"yes"})", R"({"sim_battery":2})"}) {
    auto failures = startModule("nao", bad, false, "nao-bridge");
    ASSERT_EQ(failures.size(), 1u) << bad;
    EXPECT_NE(failures[0].find("MODULE-CONFIG"), std::string::npos) << failures[0];
  }
  // What a declaration cannot say, the module checks in init.
  for (const char* bad : {R"({"rates_hz":{"joints":500}})", R"({"queues":["nodot"]})",
                          R"({"reconnect_min_ms":5000,"reconnect_max_ms":1000})"}) {
    auto failures = startModule("nao", bad, false, "nao-bridge");
    ASSERT_EQ(failures.size(), 1u) << bad;
    EXPECT_NE(failures[0].find("MODULE-INIT"), std::string::npos) << failures[0];
  }
  std::string lines;
  for (const auto& l : log.lines()) lines += l + "\n";
  for (const char* key :
       {"config.backend", "config.port", "config.authenticate", "config.sim_battery",
        "config.rates_hz", "config.queues", "config.reconnect_min_ms"}) {
    EXPECT_NE(lines.find(key), std::string::npos) << key << "\n" << lines;
  }
}

}  // namespace
}  // namespace skr::test
