// SPDX-License-Identifier: Apache-2.0
#include "nao_model.h"

#include <algorithm>

namespace skr::nao {

// Limits in radians from the NAO V5 joint documentation; speeds are the motors' no-load speeds
// after reduction (type 1 legs/head-pitch class, type 2 arms), rounded.
const std::array<Joint, 26> kJoints = {{
    {"HeadYaw", -2.0857, 2.0857, 8.27},          {"HeadPitch", -0.6720, 0.5149, 7.19},
    {"LShoulderPitch", -2.0857, 2.0857, 8.27},   {"LShoulderRoll", -0.3142, 1.3265, 7.19},
    {"LElbowYaw", -2.0857, 2.0857, 8.27},        {"LElbowRoll", -1.5446, -0.0349, 7.19},
    {"LWristYaw", -1.8238, 1.8238, 24.6},        {"LHand", 0.0, 1.0, 8.33},
    {"LHipYawPitch", -1.145303, 0.740810, 4.16}, {"LHipRoll", -0.379472, 0.790477, 4.16},
    {"LHipPitch", -1.535889, 0.484090, 6.40},    {"LKneePitch", -0.092346, 2.112528, 6.40},
    {"LAnklePitch", -1.189516, 0.922747, 6.40},  {"LAnkleRoll", -0.397880, 0.769001, 4.16},
    {"RHipYawPitch", -1.145303, 0.740810, 4.16}, {"RHipRoll", -0.790477, 0.379472, 4.16},
    {"RHipPitch", -1.535889, 0.484090, 6.40},    {"RKneePitch", -0.103083, 2.120198, 6.40},
    {"RAnklePitch", -1.186448, 0.932056, 6.40},  {"RAnkleRoll", -0.768992, 0.397935, 4.16},
    {"RShoulderPitch", -2.0857, 2.0857, 8.27},   {"RShoulderRoll", -1.3265, 0.3142, 7.19},
    {"RElbowYaw", -2.0857, 2.0857, 8.27},        {"RElbowRoll", 0.0349, 1.5446, 7.19},
    {"RWristYaw", -1.8238, 1.8238, 24.6},        {"RHand", 0.0, 1.0, 8.33},
}};

const std::array<const char*, 9> kLedGroups = {"AllLeds",       "FaceLeds",     "ChestLeds",
                                               "EarLeds",       "FeetLeds",     "LeftFaceLeds",
                                               "RightFaceLeds", "LeftFootLeds", "RightFootLeds"};

std::optional<std::size_t> jointIndex(std::string_view name) {
  for (std::size_t i = 0; i < kJoints.size(); ++i) {
    if (name == kJoints[i].name) return i;
  }
  return std::nullopt;
}

std::vector<std::string> jointNames() {
  std::vector<std::string> v;
  for (const Joint& j : kJoints) v.emplace_back(j.name);
  return v;
}

namespace {

// Mirrors a left-side description to the full body: head, larm, lleg given; right = mirrored.
std::array<double, 26> body(double head_pitch, std::array<double, 6> larm,
                            std::array<double, 6> lleg) {
  std::array<double, 26> a{};
  a[0] = 0;
  a[1] = head_pitch;
  for (int i = 0; i < 6; ++i) a[2 + i] = larm[i];
  for (int i = 0; i < 6; ++i) a[8 + i] = lleg[i];
  // Right leg: rolls change sign; right arm: roll and elbow yaw/roll change sign.
  for (int i = 0; i < 6; ++i) a[14 + i] = (i == 1 || i == 5) ? -lleg[i] : lleg[i];
  a[20] = larm[0];
  a[21] = -larm[1];
  a[22] = -larm[2];
  a[23] = -larm[3];
  a[24] = -larm[4];
  a[25] = larm[5];
  for (std::size_t i = 0; i < a.size(); ++i) {
    a[i] = std::clamp(a[i], kJoints[i].min_rad, kJoints[i].max_rad);
  }
  return a;
}

}  // namespace

const std::map<std::string, std::array<double, 26>>& postures() {
  //                 ShPitch ShRoll ElbYaw ElbRoll Wrist Hand | HipYP HipRoll HipPitch Knee
  //                 AnklePitch AnkleRoll
  static const std::map<std::string, std::array<double, 26>> kPostures = {
      {"StandInit",
       body(0.0, {1.40, 0.30, -1.39, -1.00, 0.0, 0.25}, {0.0, 0.0, -0.45, 0.70, -0.35, 0.0})},
      {"Stand",
       body(0.0, {1.40, 0.20, -1.39, -0.50, 0.0, 0.25}, {0.0, 0.0, -0.17, 0.09, 0.09, 0.0})},
      {"StandZero", body(0.0, {0, 0, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0})},
      {"Crouch",
       body(0.0, {1.55, 0.14, -0.80, -1.00, 0.0, 0.0}, {-0.24, 0.0, -0.87, 2.11, -1.18, 0.0})},
      {"Sit",
       body(0.0, {0.90, 0.10, -0.50, -0.60, 0.0, 0.0}, {-0.60, 0.20, -1.50, 0.60, 0.90, 0.0})},
      {"SitRelax",
       body(0.0, {1.20, 0.20, -0.40, -0.50, 0.0, 0.0}, {-0.60, 0.30, -1.50, 1.00, 0.50, 0.0})},
      {"LyingBelly",
       body(-0.30, {-1.50, 0.10, 0.0, -0.10, 0.0, 0.0}, {0.0, 0.0, 0.0, 0.0, 0.0, 0.0})},
      {"LyingBack", body(0.30, {1.50, 0.10, 0.0, -0.10, 0.0, 0.0}, {0.0, 0.0, 0.0, 0.0, 0.0, 0.0})},
  };
  return kPostures;
}

std::string postureFamily(const std::string& posture) {
  if (posture.rfind("Stand", 0) == 0) return "Standing";
  if (posture == "Crouch") return "Crouching";
  if (posture.rfind("Sit", 0) == 0) return "Sitting";
  if (posture == "LyingBelly" || posture == "LyingBack") return posture;
  return "Unknown";
}

}  // namespace skr::nao
