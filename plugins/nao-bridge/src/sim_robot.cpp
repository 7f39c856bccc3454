// SPDX-License-Identifier: Apache-2.0
#include "sim_robot.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace skr::nao {
namespace {

// Drain per second at drain_scale 1: about 3 h resting, 90 min awake, 60 min walking.
constexpr double kDrainRest = 1.0 / (3 * 3600);
constexpr double kDrainAwake = 1.0 / (90 * 60);
constexpr double kDrainWalk = 1.0 / (60 * 60);
constexpr double kSonarHalfAngle = 0.35;  // the two sonars look 20 degrees left and right
constexpr double kFallDistance_m = 0.15;  // closer than this to a wall while walking: a fall

}  // namespace

SimRobot::SimRobot(SimOptions o) : opt_(o), battery_(std::clamp(o.battery, 0.0, 1.0)) {
  angles_ = postures().at("Crouch");
  targets_ = angles_;
  posture_ = "Crouch";
}

double SimRobot::angle(const std::string& joint) const {
  const auto i = jointIndex(joint);
  return i ? angles_[*i] : std::numeric_limits<double>::quiet_NaN();
}

bool SimRobot::moving() const noexcept {
  for (std::size_t i = 0; i < angles_.size(); ++i) {
    if (std::abs(angles_[i] - targets_[i]) > 1e-9) return true;
  }
  return false;
}

void SimRobot::setTargets(const std::array<double, 26>& a, double speed) {
  for (std::size_t i = 0; i < a.size(); ++i) {
    targets_[i] = std::clamp(a[i], kJoints[i].min_rad, kJoints[i].max_rad);
    speeds_[i] = speed * kJoints[i].max_speed_rad_s;
  }
}

CommandResult SimRobot::execute(const Command& c) {
  auto asleep = [] {
    return CommandResult::failure(CommandError::robot_error,
                                  "the robot is resting: send {\"cmd\":\"wake\"} first");
  };
  if (const auto* s = std::get_if<Say>(&c)) {
    said_ = s->text;
    return CommandResult::success();
  }
  if (const auto* l = std::get_if<Leds>(&c)) {
    leds_[l->group] = l->rgb;
    return CommandResult::success();
  }
  if (std::holds_alternative<Wake>(c)) {
    if (!awake_) {
      awake_ = true;
      if (posture_ != "Stand") {
        setTargets(postures().at("StandInit"), 0.3);
        pending_posture_ = "StandInit";
      }
    }
    return CommandResult::success();
  }
  if (std::holds_alternative<Rest>(c)) {
    walking_ = false;
    velocity_ = {};
    setTargets(postures().at("Crouch"), 0.3);
    pending_posture_ = "Crouch";
    awake_ = false;  // stiffness off once crouched; the motion still completes in step()
    return CommandResult::success();
  }
  if (std::holds_alternative<Stop>(c)) {
    walking_ = false;
    velocity_ = {};
    return CommandResult::success();
  }
  if (!awake_) return asleep();
  if (const auto* p = std::get_if<Posture>(&c)) {
    walking_ = false;
    velocity_ = {};
    fallen_ = false;
    setTargets(postures().at(p->name), p->speed);
    pending_posture_ = p->name;
    return CommandResult::success();
  }
  if (const auto* j = std::get_if<Joints>(&c)) {
    if (fallen_) return CommandResult::failure(CommandError::robot_error, "the robot has fallen");
    for (std::size_t k = 0; k < j->names.size(); ++k) {
      const auto i = jointIndex(j->names[k]);
      if (!i) return CommandResult::failure(CommandError::out_of_range, "unknown joint");
      targets_[*i] = std::clamp(j->angles[k], kJoints[*i].min_rad, kJoints[*i].max_rad);
      speeds_[*i] = j->speed * kJoints[*i].max_speed_rad_s;
    }
    return CommandResult::success();
  }
  if (const auto* w = std::get_if<Walk>(&c)) {
    if (fallen_) return CommandResult::failure(CommandError::robot_error, "the robot has fallen");
    if (postureFamily(posture_) != "Standing") {
      setTargets(postures().at("StandInit"), 0.5);  // ALMotion stands up before walking too
      pending_posture_ = "StandInit";
    }
    velocity_ = *w;
    walking_ = w->x != 0 || w->y != 0 || w->theta != 0;
    return CommandResult::success();
  }
  return CommandResult::failure(CommandError::unknown_command, "not simulated");
}

void SimRobot::step(double dt) {
  if (dt <= 0) return;
  for (std::size_t i = 0; i < angles_.size(); ++i) {
    const double diff = targets_[i] - angles_[i];
    const double max = speeds_[i] * dt;
    angles_[i] += std::clamp(diff, -max, max);
    angles_[i] = std::clamp(angles_[i], kJoints[i].min_rad, kJoints[i].max_rad);
  }
  if (!pending_posture_.empty() && !moving()) {
    posture_ = pending_posture_;
    pending_posture_.clear();
  }
  // Walking starts once standing; odometry in the room frame.
  if (walking_ && postureFamily(posture_) == "Standing" && pending_posture_.empty()) {
    const double vx = velocity_.x * kWalkMaxX_m_s;
    const double vy = velocity_.y * kWalkMaxY_m_s;
    const double c = std::cos(pose_.theta_rad), s = std::sin(pose_.theta_rad);
    pose_.x_m += (vx * c - vy * s) * dt;
    pose_.y_m += (vx * s + vy * c) * dt;
    pose_.theta_rad =
        std::remainder(pose_.theta_rad + velocity_.theta * kWalkMaxTheta_rad_s * dt, 2 * M_PI);
    const double half = opt_.room_size_m / 2;
    if (half - std::abs(pose_.x_m) < kFallDistance_m ||
        half - std::abs(pose_.y_m) < kFallDistance_m) {
      fallen_ = true;
      walking_ = false;
      velocity_ = {};
      posture_ = "LyingBelly";
      pending_posture_.clear();
      angles_ = postures().at("LyingBelly");
      targets_ = angles_;
    }
  }
  const double drain = walking_ ? kDrainWalk : (awake_ ? kDrainAwake : kDrainRest);
  battery_ = std::max(0.0, battery_ - drain * opt_.drain_scale * dt);
}

// Distance along `heading` (room frame) from the robot to the room's walls.
double SimRobot::wallDistance(double heading) const {
  const double half = opt_.room_size_m / 2;
  const double dx = std::cos(heading), dy = std::sin(heading);
  double best = std::numeric_limits<double>::infinity();
  if (dx > 1e-9) best = std::min(best, (half - pose_.x_m) / dx);
  if (dx < -1e-9) best = std::min(best, (-half - pose_.x_m) / dx);
  if (dy > 1e-9) best = std::min(best, (half - pose_.y_m) / dy);
  if (dy < -1e-9) best = std::min(best, (-half - pose_.y_m) / dy);
  return std::clamp(best, kSonarMin_m, kSonarMax_m);
}

double SimRobot::sonarLeft() const {
  return wallDistance(pose_.theta_rad + kSonarHalfAngle);
}
double SimRobot::sonarRight() const {
  return wallDistance(pose_.theta_rad - kSonarHalfAngle);
}

}  // namespace skr::nao
