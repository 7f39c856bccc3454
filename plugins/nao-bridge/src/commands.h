// SPDX-License-Identifier: Apache-2.0
// The bridge's JSON commands, parsed and range-checked before they reach a backend:
//   {"cmd":"say","text":"hello"}
//   {"cmd":"posture","name":"Stand","speed":0.5}              speed: fraction of max, (0, 1]
//   {"cmd":"head","yaw":0.3,"pitch":-0.1,"speed":0.2}          radians; speed optional (0.2)
//   {"cmd":"joints","names":["LShoulderPitch"],"angles":[0.5],"speed":0.2}
//   {"cmd":"walk","x":0.5,"y":0,"theta":0}                     velocities, fractions in [-1, 1]
//   {"cmd":"stop"}  {"cmd":"rest"}  {"cmd":"wake"}
//   {"cmd":"leds","group":"FaceLeds","rgb":"#ff0000","duration":0.5}
// Answers are {"ok":true} or {"ok":false,"code":"<code>","error":"<text>"}.
#pragma once

#include <json/value.h>

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

namespace skr::nao {

enum class CommandError {
  none,
  bad_request,  // not JSON, not an object, a missing or mistyped field
  unknown_command,
  out_of_range,         // a value outside a joint limit or an allowed range
  not_connected,        // the robot is not connected (or the connection was lost meanwhile)
  robot_error,          // the robot refused or failed
  service_unavailable,  // the robot is connected but lacks the service this command needs
};

[[nodiscard]] const char* commandErrorCode(CommandError e) noexcept;

struct Say {
  std::string text;
};
struct Posture {
  std::string name;
  double speed = 0.5;
};
struct Joints {  // head commands become Joints on HeadYaw/HeadPitch
  std::vector<std::string> names;
  std::vector<double> angles;
  double speed = 0.2;
};
struct Walk {
  double x = 0, y = 0, theta = 0;
};
struct Stop {};
struct Rest {};
struct Wake {};
struct Leds {
  std::string group;
  std::uint32_t rgb = 0;  // 0x00RRGGBB
  double duration_s = 0;
};

using Command = std::variant<Say, Posture, Joints, Walk, Stop, Rest, Wake, Leds>;

struct CommandResult {
  CommandError error = CommandError::none;
  std::string message;
  [[nodiscard]] bool ok() const noexcept { return error == CommandError::none; }
  // {"ok":true} or {"ok":false,"code":..,"error":..}, as a value and as compact text.
  [[nodiscard]] Json::Value toJson() const;
  [[nodiscard]] std::string json() const;
  static CommandResult success() { return {}; }
  static CommandResult failure(CommandError e, std::string message) {
    return {e, std::move(message)};
  }
};

struct Parsed {
  Command command;
  CommandResult result;  // failure: why it was refused
};

// Parses `json` (an object with "cmd"; strict JSON, at most kMaxCommandBytes and nested at most
// kMaxCommandDepth deep). When the object has no "cmd", `default_cmd` (a service request's
// command name) is used; then empty text or null stands for {}.
[[nodiscard]] Parsed parseCommand(const std::string& json, const std::string& default_cmd = {});
[[nodiscard]] const char* commandName(const Command& c) noexcept;

constexpr std::size_t kMaxSayBytes = 2000;
constexpr std::size_t kMaxCommandBytes = 64u << 10;
constexpr std::size_t kMaxCommandDepth = 8;

}  // namespace skr::nao
