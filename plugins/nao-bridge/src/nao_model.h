// SPDX-License-Identifier: Apache-2.0
// What the bridge knows about a Nao v5 (H25): joint names, limits and speeds (Aldebaran's
// "NAO - Joints" pages for V5), the standard postures and the LED groups of ALLeds.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::nao {

struct Joint {
  const char* name;
  double min_rad;  // for LHand/RHand: 0 (closed) .. 1 (open), not radians
  double max_rad;
  double max_speed_rad_s;  // at fractionMaxSpeed 1
};

// The 26 joints of the "Body" chain, in ALMotion's order (head, left arm, left leg, right leg,
// right arm).
extern const std::array<Joint, 26> kJoints;

[[nodiscard]] std::optional<std::size_t> jointIndex(std::string_view name);
[[nodiscard]] std::vector<std::string> jointNames();

// Target angles of the postures ALRobotPosture knows, in kJoints order, inside the limits.
[[nodiscard]] const std::map<std::string, std::array<double, 26>>& postures();
// The posture family a posture belongs to ("Standing", "Crouching", "Sitting", "LyingBelly",
// "LyingBack").
[[nodiscard]] std::string postureFamily(const std::string& posture);

// Walk velocities at moveToward(1, 1, 1).
constexpr double kWalkMaxX_m_s = 0.10;
constexpr double kWalkMaxY_m_s = 0.07;
constexpr double kWalkMaxTheta_rad_s = 0.50;

// ALLeds groups accepted by the "leds" command.
extern const std::array<const char*, 9> kLedGroups;

// Sonar range of the V5 sensors.
constexpr double kSonarMin_m = 0.25;
constexpr double kSonarMax_m = 2.55;

}  // namespace skr::nao
