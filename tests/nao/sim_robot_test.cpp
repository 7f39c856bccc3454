// SPDX-License-Identifier: Apache-2.0
// The command parser's refusals and the simulated Nao: every command changes its state as a
// Nao would, joints stay inside the V5 limits, walking integrates odometry, the battery drains.
#include "sim_robot.h"
#include "commands.h"
#include "nao_model.h"

#include <gtest/gtest.h>

#include <cmath>

namespace skr::nao {
namespace {

Command ok(const std::string& json) {
  Parsed p = parseCommand(json);
  EXPECT_TRUE(p.result.ok()) << json << ": " << p.result.message;
  return p.command;
}

CommandError refusal(const std::string& json, const std::string& default_cmd = {}) {
  Parsed p = parseCommand(json, default_cmd);
  EXPECT_FALSE(p.result.ok()) << json;
  EXPECT_FALSE(p.result.message.empty()) << json;
  return p.result.error;
}

void settle(SimRobot& r, double seconds) {
  for (double t = 0; t < seconds; t += 0.02) r.step(0.02);
}

bool insideLimits(const SimRobot& r) {
  for (std::size_t i = 0; i < kJoints.size(); ++i) {
    if (r.angles()[i] < kJoints[i].min_rad - 1e-12 || r.angles()[i] > kJoints[i].max_rad + 1e-12) {
      return false;
    }
  }
  return true;
}

TEST(Commands, RefusesWhatANaoCannotDo) {
  EXPECT_EQ(refusal("{\"cmd\":\"dance\"}"), CommandError::unknown_command);
  EXPECT_EQ(refusal("not json"), CommandError::bad_request);
  EXPECT_EQ(refusal("[1]"), CommandError::bad_request);
  EXPECT_EQ(refusal(std::string(5000, '[')), CommandError::bad_request);
  // The module-support parser's limits: nesting past kMaxCommandDepth, duplicate keys.
  const Parsed deep = parseCommand(R"({"cmd":"say","text":"x","n":[[[[[[[[1]]]]]]]]})");
  EXPECT_EQ(deep.result.error, CommandError::bad_request);
  EXPECT_NE(deep.result.message.find("not JSON"), std::string::npos) << deep.result.message;
  EXPECT_EQ(refusal(R"({"cmd":"say","text":"a","text":"b"})"), CommandError::bad_request);
  EXPECT_TRUE(parseCommand(R"({"cmd":"say","text":"x","n":[[[[[[1]]]]]]})").result.ok());
  EXPECT_EQ(refusal("{}"), CommandError::bad_request);
  EXPECT_EQ(refusal(R"({"cmd":"head","yaw":2.2})"), CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"head","pitch":0.6})"), CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"head","yaw":"left"})"), CommandError::bad_request);
  EXPECT_EQ(refusal(R"({"cmd":"joints","names":["LElbowRoll"],"angles":[0.5]})"),
            CommandError::out_of_range);  // the left elbow only bends to negative angles
  EXPECT_EQ(refusal(R"({"cmd":"joints","names":["LKneePitch"],"angles":[2.2]})"),
            CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"joints","names":["Tail"],"angles":[0]})"),
            CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"joints","names":["HeadYaw"],"angles":[0,1]})"),
            CommandError::bad_request);
  EXPECT_EQ(refusal(R"({"cmd":"joints","names":["HeadYaw"],"angles":[0],"speed":1.5})"),
            CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"walk","x":1.2})"), CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"posture","name":"Handstand"})"), CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"posture","name":"Stand","speed":0})"), CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"leds","group":"FaceLeds","rgb":"red"})"), CommandError::bad_request);
  EXPECT_EQ(refusal(R"({"cmd":"leds","group":"TailLeds","rgb":"#ff0000"})"),
            CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"say","text":""})"), CommandError::out_of_range);
  EXPECT_EQ(refusal(R"({"cmd":"say"})"), CommandError::bad_request);
  // The service's command name stands in for "cmd".
  EXPECT_EQ(refusal(R"({"yaw":9})", "head"), CommandError::out_of_range);
  EXPECT_TRUE(parseCommand("{}", "stop").result.ok());
  EXPECT_TRUE(parseCommand("null", "wake").result.ok());
  EXPECT_TRUE(parseCommand("", "wake").result.ok());  // a request without a value
  EXPECT_EQ(refusal(""), CommandError::bad_request);
  const Leds l = std::get<Leds>(ok(R"({"cmd":"leds","group":"FaceLeds","rgb":[0,128,255]})"));
  EXPECT_EQ(l.rgb, 0x0080ffu);
  EXPECT_EQ(parseCommand(R"({"cmd":"dance"})").result.json(),
            R"({"code":"unknown_command","error":"unknown command \"dance\"","ok":false})");
}

TEST(SimRobot, StartsCrouchedAndRestingAndRefusesMotionUntilAwake) {
  SimRobot r;
  EXPECT_EQ(r.posture(), "Crouch");
  EXPECT_FALSE(r.awake());
  const auto res = r.execute(ok(R"({"cmd":"head","yaw":0.5})"));
  EXPECT_EQ(res.error, CommandError::robot_error);
  EXPECT_TRUE(r.execute(ok(R"({"cmd":"wake"})")).ok());
  EXPECT_TRUE(r.awake());
  settle(r, 3);
  EXPECT_EQ(r.posture(), "StandInit");
  EXPECT_TRUE(insideLimits(r));
}

TEST(SimRobot, HeadAndJointsMoveAtTheirSpeedToTheTarget) {
  SimRobot r;
  ASSERT_TRUE(r.execute(Wake{}).ok());
  settle(r, 3);
  ASSERT_TRUE(r.execute(ok(R"({"cmd":"head","yaw":1.0,"pitch":-0.5,"speed":0.1})")).ok());
  r.step(0.5);  // 0.1 * 8.27 rad/s * 0.5 s = 0.41 rad
  EXPECT_NEAR(r.angle("HeadYaw"), 0.1 * 8.27 * 0.5, 1e-9);
  EXPECT_TRUE(r.moving());
  settle(r, 2);
  EXPECT_NEAR(r.angle("HeadYaw"), 1.0, 1e-9);
  EXPECT_NEAR(r.angle("HeadPitch"), -0.5, 1e-9);
  ASSERT_TRUE(r.execute(ok(R"({"cmd":"joints","names":["LShoulderPitch","RElbowRoll","LHand"],
                                 "angles":[-2.0857,1.5446,1.0],"speed":1})"))
                  .ok());
  settle(r, 1);
  EXPECT_NEAR(r.angle("LShoulderPitch"), -2.0857, 1e-9);
  EXPECT_NEAR(r.angle("RElbowRoll"), 1.5446, 1e-9);
  EXPECT_NEAR(r.angle("LHand"), 1.0, 1e-9);
  EXPECT_TRUE(insideLimits(r));
}

TEST(SimRobot, EveryPostureIsReachedInsideTheLimits) {
  SimRobot r;
  ASSERT_TRUE(r.execute(Wake{}).ok());
  for (const auto& [name, target] : postures()) {
    ASSERT_TRUE(r.execute(Posture{name, 1.0}).ok()) << name;
    settle(r, 2);
    EXPECT_EQ(r.posture(), name);
    EXPECT_FALSE(r.moving());
    EXPECT_TRUE(insideLimits(r)) << name;
    for (std::size_t i = 0; i < target.size(); ++i) EXPECT_NEAR(r.angles()[i], target[i], 1e-9);
  }
}

TEST(SimRobot, WalkingIntegratesOdometryAndStopHaltsIt) {
  SimRobot r;
  ASSERT_TRUE(r.execute(Wake{}).ok());
  settle(r, 3);
  const double sonar_before = r.sonarLeft();
  ASSERT_TRUE(r.execute(ok(R"({"cmd":"walk","x":1.0})")).ok());
  EXPECT_TRUE(r.walking());
  settle(r, 5);  // 0.1 m/s
  EXPECT_NEAR(r.pose().x_m, 0.5, 0.03);
  EXPECT_NEAR(r.pose().y_m, 0.0, 1e-9);
  EXPECT_LT(r.sonarLeft(), sonar_before);
  ASSERT_TRUE(r.execute(ok(R"({"cmd":"stop"})")).ok());
  const Pose stopped = r.pose();
  settle(r, 2);
  EXPECT_FALSE(r.walking());
  EXPECT_EQ(r.pose().x_m, stopped.x_m);
  ASSERT_TRUE(r.execute(ok(R"({"cmd":"walk","theta":1.0})")).ok());
  settle(r, 1);
  EXPECT_NEAR(r.pose().theta_rad, 0.5, 0.03);
}

TEST(SimRobot, WalkingIntoAWallIsAFallAndAPostureRecovers) {
  SimRobot r(SimOptions{2.0, 1.0, 1.0});
  ASSERT_TRUE(r.execute(Wake{}).ok());
  settle(r, 3);
  ASSERT_TRUE(r.execute(Walk{1.0, 0, 0}).ok());
  settle(r, 20);  // the wall is 1 m ahead
  EXPECT_TRUE(r.fallen());
  EXPECT_FALSE(r.walking());
  EXPECT_EQ(r.posture(), "LyingBelly");
  EXPECT_EQ(r.execute(Walk{1.0, 0, 0}).error, CommandError::robot_error);
  ASSERT_TRUE(r.execute(Posture{"Stand", 0.5}).ok());
  EXPECT_FALSE(r.fallen());
  EXPECT_NEAR(r.sonarLeft(), kSonarMin_m, 1e-9);  // nose to the wall
}

TEST(SimRobot, BatteryDrainsFasterWhenWalkingAndRestStopsEverything) {
  SimRobot r(SimOptions{40.0, 1.0, 60.0});
  settle(r, 10);
  const double resting = 1.0 - r.battery();
  ASSERT_TRUE(r.execute(Wake{}).ok());
  settle(r, 3);
  const double before = r.battery();
  ASSERT_TRUE(r.execute(Walk{0.5, 0, 0}).ok());
  settle(r, 10);
  const double walking = before - r.battery();
  EXPECT_GT(resting, 0);
  EXPECT_GT(walking, resting * 2);
  ASSERT_TRUE(r.execute(Rest{}).ok());
  EXPECT_FALSE(r.awake());
  EXPECT_FALSE(r.walking());
  settle(r, 3);
  EXPECT_EQ(r.posture(), "Crouch");
  r.step(1e5);
  EXPECT_EQ(r.battery(), 0.0);  // never negative
}

TEST(SimRobot, SayAndLedsAreRecorded) {
  SimRobot r;
  EXPECT_TRUE(r.execute(Say{"bonjour"}).ok());
  EXPECT_EQ(r.lastSaid(), "bonjour");
  EXPECT_TRUE(r.execute(ok(R"({"cmd":"leds","group":"ChestLeds","rgb":"#00ff00"})")).ok());
  EXPECT_EQ(r.leds().at("ChestLeds"), 0x00ff00u);
}

}  // namespace
}  // namespace skr::nao
