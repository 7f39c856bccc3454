// SPDX-License-Identifier: Apache-2.0
#include "backends.h"

#include <skrobot/support/json.hpp>

#include <json/value.h>
#include <poll.h>

namespace skr::nao {

SimBackend::SimBackend(SimOptions o) : robot_(o), last_ns_(qi::monotonicNs()) {}

void SimBackend::advance() {
  const std::int64_t now = qi::monotonicNs();
  robot_.step(static_cast<double>(now - last_ns_) / 1e9);
  last_ns_ = now;
}

void SimBackend::execute(const Command& c, Done done) {
  advance();
  done(robot_.execute(c));
}

void SimBackend::read(StateKind k, StateDone done) {
  advance();
  Json::Value v(Json::objectValue);
  switch (k) {
    case StateKind::joints:
      v["angles"] = Json::Value(Json::arrayValue);
      for (double a : robot_.angles()) v["angles"].append(a);
      break;
    case StateKind::sonar:
      v["left"] = robot_.sonarLeft();
      v["right"] = robot_.sonarRight();
      break;
    case StateKind::battery:
      v["charge"] = robot_.battery();
      break;
    case StateKind::posture:
      v["posture"] = robot_.posture();
      v["family"] = postureFamily(robot_.posture());
      v["moving"] = robot_.moving() || robot_.walking();
      v["odometry"]["x"] = robot_.pose().x_m;
      v["odometry"]["y"] = robot_.pose().y_m;
      v["odometry"]["theta"] = robot_.pose().theta_rad;
      break;
    case StateKind::fall:
      v["fallen"] = robot_.fallen();
      break;
  }
  done(support::writeJson(v));
}

Result<void> SimBackend::pump(int timeout_ms, int wake_fd) {
  pollfd p{wake_fd, POLLIN, 0};
  ::poll(&p, wake_fd >= 0 ? 1 : 0, timeout_ms);
  advance();
  return {};
}

}  // namespace skr::nao
