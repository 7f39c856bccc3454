// SPDX-License-Identifier: Apache-2.0
// A kinematic Nao: joints move toward their targets at bounded speeds inside their limits,
// postures are joint targets, walking integrates odometry, the battery drains, two sonars see
// the walls of a square room, and walking into a wall makes it fall.
// Not thread-safe: owned by one thread (the robot worker, or a test).
#pragma once

#include "commands.h"
#include "nao_model.h"

#include <array>
#include <map>
#include <string>

namespace skr::nao {

struct SimOptions {
  double room_size_m = 4.0;  // square room centred on the start position
  double battery = 1.0;      // initial charge, 0..1
  double drain_scale = 1.0;  // multiplies the drain rates (demos may speed it up)
};

struct Pose {
  double x_m = 0, y_m = 0, theta_rad = 0;
};

class SimRobot {
 public:
  explicit SimRobot(SimOptions o = {});

  // Applies a validated command now (its motion happens in step()).
  CommandResult execute(const Command& c);
  // Advances the simulation by dt seconds.
  void step(double dt_s);

  [[nodiscard]] const std::array<double, 26>& angles() const noexcept { return angles_; }
  [[nodiscard]] double angle(const std::string& joint) const;
  [[nodiscard]] bool awake() const noexcept { return awake_; }
  [[nodiscard]] bool walking() const noexcept { return walking_; }
  [[nodiscard]] bool fallen() const noexcept { return fallen_; }
  [[nodiscard]] bool moving() const noexcept;  // some joint is not at its target
  [[nodiscard]] const std::string& posture() const noexcept { return posture_; }
  [[nodiscard]] const Pose& pose() const noexcept { return pose_; }
  [[nodiscard]] double battery() const noexcept { return battery_; }
  [[nodiscard]] double sonarLeft() const;
  [[nodiscard]] double sonarRight() const;
  [[nodiscard]] const std::string& lastSaid() const noexcept { return said_; }
  [[nodiscard]] const std::map<std::string, std::uint32_t>& leds() const noexcept { return leds_; }

 private:
  void setTargets(const std::array<double, 26>& a, double speed);
  double wallDistance(double heading) const;

  SimOptions opt_;
  std::array<double, 26> angles_{};
  std::array<double, 26> targets_{};
  std::array<double, 26> speeds_{};  // rad/s per joint
  std::string posture_;
  std::string pending_posture_;  // reached when the joints arrive
  bool awake_ = false;
  bool walking_ = false;
  bool fallen_ = false;
  Walk velocity_;
  Pose pose_;
  double battery_;
  std::string said_;
  std::map<std::string, std::uint32_t> leds_;
};

}  // namespace skr::nao
