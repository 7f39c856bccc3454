// SPDX-License-Identifier: Apache-2.0
#include "commands.h"

#include "nao_model.h"

#include <skrobot/support/json.hpp>

#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

namespace skr::nao {

const char* commandErrorCode(CommandError e) noexcept {
  switch (e) {
    case CommandError::none:
      return "ok";
    case CommandError::bad_request:
      return "bad_request";
    case CommandError::unknown_command:
      return "unknown_command";
    case CommandError::out_of_range:
      return "out_of_range";
    case CommandError::not_connected:
      return "not_connected";
    case CommandError::robot_error:
      return "robot_error";
    case CommandError::service_unavailable:
      return "service_unavailable";
  }
  return "?";
}

Json::Value CommandResult::toJson() const {
  Json::Value v(Json::objectValue);
  v["ok"] = ok();
  if (!ok()) {
    v["code"] = commandErrorCode(error);
    v["error"] = message;
  }
  return v;
}

std::string CommandResult::json() const {
  return support::writeJson(toJson());
}

const char* commandName(const Command& c) noexcept {
  constexpr const char* kNames[] = {"say",  "posture", "joints", "walk",
                                    "stop", "rest",    "wake",   "leds"};
  return kNames[c.index()];
}

namespace {

struct Refusal {
  CommandResult result;
};

[[noreturn]] void refuse(CommandError e, const std::string& why) {
  throw Refusal{CommandResult::failure(e, why)};
}

double number(const Json::Value& o, const char* key, std::optional<double> def, double lo,
              double hi) {
  if (!o.isMember(key)) {
    if (!def) refuse(CommandError::bad_request, std::string("missing \"") + key + "\"");
    return *def;
  }
  const Json::Value& v = o[key];
  if (!v.isNumeric() || v.isBool()) {
    refuse(CommandError::bad_request, std::string("\"") + key + "\" must be a number");
  }
  const double d = v.asDouble();
  if (!std::isfinite(d) || d < lo || d > hi) {
    std::ostringstream s;
    s << "\"" << key << "\" = " << d << " is outside [" << lo << ", " << hi << "]";
    refuse(CommandError::out_of_range, s.str());
  }
  return d;
}

std::string text(const Json::Value& o, const char* key) {
  if (!o[key].isString()) {
    refuse(CommandError::bad_request, std::string("\"") + key + "\" must be a string");
  }
  return o[key].asString();
}

double checkedAngle(const std::string& name, const Json::Value& v) {
  const auto i = jointIndex(name);
  if (!i) refuse(CommandError::out_of_range, "unknown joint \"" + name + "\"");
  if (!v.isNumeric() || v.isBool()) {
    refuse(CommandError::bad_request, "angle of " + name + " must be a number");
  }
  const double a = v.asDouble();
  const Joint& j = kJoints[*i];
  if (!std::isfinite(a) || a < j.min_rad || a > j.max_rad) {
    std::ostringstream s;
    s << name << " = " << a << " is outside its limits [" << j.min_rad << ", " << j.max_rad << "]";
    refuse(CommandError::out_of_range, s.str());
  }
  return a;
}

std::uint32_t parseRgb(const Json::Value& v) {
  if (v.isString()) {
    const std::string s = v.asString();
    unsigned rgb = 0;
    int used = 0;
    if (s.size() == 7 && s[0] == '#' && std::sscanf(s.c_str() + 1, "%6x%n", &rgb, &used) == 1 &&
        used == 6) {
      return rgb;
    }
    refuse(CommandError::bad_request, "\"rgb\" must look like \"#rrggbb\"");
  }
  if (v.isArray() && v.size() == 3) {
    std::uint32_t rgb = 0;
    for (const auto& c : v) {
      if (!c.isNumeric() || c.asDouble() < 0 || c.asDouble() > 255) {
        refuse(CommandError::out_of_range, "\"rgb\" components must be in [0, 255]");
      }
      rgb = (rgb << 8) | static_cast<std::uint32_t>(c.asDouble());
    }
    return rgb;
  }
  refuse(CommandError::bad_request, "\"rgb\" must be \"#rrggbb\" or [r, g, b]");
}

Command build(const std::string& cmd, const Json::Value& o) {
  if (cmd == "say") {
    std::string t = text(o, "text");
    if (t.empty() || t.size() > kMaxSayBytes) {
      refuse(CommandError::out_of_range, "\"text\" must have 1 to 2000 bytes");
    }
    return Say{std::move(t)};
  }
  if (cmd == "posture") {
    Posture p{text(o, "name"), number(o, "speed", 0.5, 0.01, 1.0)};
    if (postures().count(p.name) == 0) {
      refuse(CommandError::out_of_range, "unknown posture \"" + p.name + "\"");
    }
    return p;
  }
  if (cmd == "head") {
    Joints j;
    j.speed = number(o, "speed", 0.2, 0.01, 1.0);
    for (const char* key : {"yaw", "pitch"}) {
      if (!o.isMember(key)) continue;
      const std::string name = std::string("Head") + (key[0] == 'y' ? "Yaw" : "Pitch");
      j.angles.push_back(checkedAngle(name, o[key]));
      j.names.push_back(name);
    }
    if (j.names.empty()) refuse(CommandError::bad_request, "head needs \"yaw\" and/or \"pitch\"");
    return j;
  }
  if (cmd == "joints") {
    const Json::Value& names = o["names"];
    const Json::Value& angles = o["angles"];
    if (!names.isArray() || !angles.isArray() || names.size() != angles.size() || names.empty() ||
        names.size() > kJoints.size()) {
      refuse(CommandError::bad_request,
             "\"names\" and \"angles\" must be arrays of the same length (1 to 26)");
    }
    Joints j;
    j.speed = number(o, "speed", 0.2, 0.01, 1.0);
    for (Json::ArrayIndex i = 0; i < names.size(); ++i) {
      if (!names[i].isString()) refuse(CommandError::bad_request, "joint names must be strings");
      j.angles.push_back(checkedAngle(names[i].asString(), angles[i]));
      j.names.push_back(names[i].asString());
    }
    return j;
  }
  if (cmd == "walk") {
    return Walk{number(o, "x", 0.0, -1, 1), number(o, "y", 0.0, -1, 1),
                number(o, "theta", 0.0, -1, 1)};
  }
  if (cmd == "stop") return Stop{};
  if (cmd == "rest") return Rest{};
  if (cmd == "wake") return Wake{};
  if (cmd == "leds") {
    Leds l;
    l.group = text(o, "group");
    bool known = false;
    for (const char* g : kLedGroups) known = known || l.group == g;
    if (!known) refuse(CommandError::out_of_range, "unknown LED group \"" + l.group + "\"");
    l.rgb = parseRgb(o["rgb"]);
    l.duration_s = number(o, "duration", 0.0, 0.0, 60.0);
    return l;
  }
  refuse(CommandError::unknown_command, "unknown command \"" + cmd + "\"");
}

}  // namespace

Parsed parseCommand(const std::string& json, const std::string& default_cmd) {
  const bool blank = json.find_first_not_of(" \t\r\n") == std::string::npos;
  Json::Value o;
  if (!blank || default_cmd.empty()) {
    auto parsed = support::parseJson(json, {kMaxCommandDepth, kMaxCommandBytes});
    if (!parsed) {
      return {Stop{}, CommandResult::failure(CommandError::bad_request,
                                             "not JSON: " + parsed.error().message)};
    }
    o = std::move(parsed.value());
  }
  if (o.isNull() && !default_cmd.empty()) o = Json::Value(Json::objectValue);
  if (!o.isObject()) {
    return {Stop{}, CommandResult::failure(CommandError::bad_request,
                                           "a command is a JSON object with \"cmd\"")};
  }
  std::string cmd = default_cmd;
  if (o.isMember("cmd")) {
    if (!o["cmd"].isString()) {
      return {Stop{},
              CommandResult::failure(CommandError::bad_request, "\"cmd\" must be a string")};
    }
    cmd = o["cmd"].asString();
  }
  if (cmd.empty()) {
    return {Stop{}, CommandResult::failure(CommandError::bad_request, "missing \"cmd\"")};
  }
  try {
    return {build(cmd, o), CommandResult::success()};
  } catch (const Refusal& r) {
    return {Stop{}, r.result};
  } catch (const Json::Exception& e) {
    return {Stop{}, CommandResult::failure(CommandError::bad_request, e.what())};
  }
}

}  // namespace skr::nao
