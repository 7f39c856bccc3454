// SPDX-License-Identifier: Apache-2.0
// A robot the bridge drives: the simulated Nao or a real one through NAOqi. All calls come from
// the bridge's robot worker thread; completions run on that thread too (from execute/read or a
// later pump).
#pragma once

#include <skrobot/result.hpp>
#include "commands.h"

#include <array>
#include <functional>
#include <map>
#include <string>

namespace skr::nao {

enum class StateKind { joints, sonar, battery, posture, fall };
constexpr std::array<StateKind, 5> kStateKinds = {
    StateKind::joints, StateKind::sonar, StateKind::battery, StateKind::posture, StateKind::fall};
[[nodiscard]] const char* stateName(StateKind k) noexcept;

class RobotBackend {
 public:
  using Done = std::function<void(CommandResult)>;
  using StateDone = std::function<void(Result<std::string>)>;  // the state as a JSON object

  virtual ~RobotBackend() = default;
  // Connects (blocking, bounded by the backend's timeouts).
  [[nodiscard]] virtual Result<void> connect() = 0;
  [[nodiscard]] virtual bool connected() const = 0;
  virtual void disconnect(const std::string& why) = 0;
  // Starts a command; `done` runs exactly once.
  virtual void execute(const Command& c, Done done) = 0;
  // Reads one kind of state; `done` runs exactly once.
  virtual void read(StateKind k, StateDone done) = 0;
  // Waits up to timeout_ms for robot I/O or for `wake_fd`, and processes it. An error means the
  // connection was lost.
  [[nodiscard]] virtual Result<void> pump(int timeout_ms, int wake_fd) = 0;
  [[nodiscard]] virtual std::string describe() const = 0;
  // While connected: the parts of the robot it lacks now (NAOqi services), each with why. A
  // command that needs one fails at once with service_unavailable; the others work.
  [[nodiscard]] virtual std::map<std::string, std::string> missing() const { return {}; }
  // Looks for the missing parts again (blocking, bounded by the backend's timeouts).
  virtual void retryMissing() {}
};

}  // namespace skr::nao
