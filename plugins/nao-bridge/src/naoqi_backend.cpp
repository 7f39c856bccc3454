// SPDX-License-Identifier: Apache-2.0
#include "backends.h"

#include <skrobot/support/json.hpp>

#include <json/value.h>

#include <cstdio>
#include <iterator>
#include <optional>

namespace skr::nao {
namespace {

using qi::Value;

// `robot_up`: the directory's connection is still open, so a lost connection was the
// service's own (its process went away), not the robot's.
CommandResult fromError(const Error& e, const std::string& service, bool robot_up) {
  if (e.code == Errc::closed || e.code == Errc::io_error) {
    if (robot_up) {
      return CommandResult::failure(CommandError::service_unavailable,
                                    "NAOqi service " + service + " unavailable: " + e.message);
    }
    return CommandResult::failure(CommandError::not_connected,
                                  "connection to the robot lost: " + e.message);
  }
  return CommandResult::failure(CommandError::robot_error, e.message);
}

}  // namespace

std::string NaoqiBackend::describe() const {
  return "naoqi " + opt_.client.host + ":" + std::to_string(opt_.client.port);
}

Result<void> NaoqiBackend::connect() {
  read_failed_ = false;
  missing_.clear();
  auto r = client_.connect(opt_.client);
  if (!r) return r;
  // Look up every service the bridge uses now, so that one the robot lacks (or that cannot be
  // reached) is reported at once, not at the first command. Only losing the directory's
  // connection meanwhile, or finding none of them (a robot that refuses every look-up, e.g.
  // NAOqi 2.5+ with "authenticate" off), fails the connection.
  std::optional<Error> first;
  for (const char* s : kServices) {
    auto found = client_.resolve(s);
    if (found) continue;
    Error e = makeError(found.error().code, std::string("NAOqi service ") + s +
                                                " unavailable: " + found.error().message);
    if (!client_.connected()) return e;
    if (!first) first = e;
    missing_[s] = found.error().message;
  }
  for (auto& [service, why] : client_.takeLost()) missing_[service] = why;
  if (missing_.size() == std::size(kServices)) {
    Error e = first ? *first
                    : makeError(Errc::closed, "NAOqi service " + missing_.begin()->first +
                                                  " unavailable: " + missing_.begin()->second);
    client_.close(e.message);
    missing_.clear();
    return e;
  }
  return {};
}

void NaoqiBackend::retryMissing() {
  for (auto it = missing_.begin(); it != missing_.end() && client_.connected();) {
    auto found = client_.resolve(it->first);
    if (found) {
      it = missing_.erase(it);
    } else {
      it->second = found.error().message;
      ++it;
    }
  }
  for (auto& [service, why] : client_.takeLost()) missing_[service] = why;
}

std::string NaoqiBackend::unavailable(const std::string& service) const {
  auto it = missing_.find(service);
  return it == missing_.end() ? "" : "NAOqi service " + service + " unavailable: " + it->second;
}

void NaoqiBackend::call(const std::string& service, const std::string& method,
                        std::vector<Value> args, Done done,
                        std::function<CommandResult(const Value&)> check) {
  if (std::string why = unavailable(service); !why.empty()) {
    return done(CommandResult::failure(CommandError::service_unavailable, std::move(why)));
  }
  auto shared = std::make_shared<Done>(std::move(done));
  auto r = client_.call(service, method, std::move(args), opt_.motion_timeout_ms,
                        [this, shared, check, service](Result<Value> v) {
                          if (!v) {
                            (*shared)(fromError(v.error(), service, client_.connected()));
                          } else {
                            (*shared)(check ? check(v.value()) : CommandResult::success());
                          }
                        });
  if (!r) (*shared)(fromError(r.error(), service, client_.connected()));
}

void NaoqiBackend::execute(const Command& c, Done done) {
  if (const auto* s = std::get_if<Say>(&c)) {
    return call("ALTextToSpeech", "say", {Value::string(s->text)}, std::move(done));
  }
  if (const auto* p = std::get_if<Posture>(&c)) {
    requested_posture_ = p->name;
    const std::string name = p->name;
    return call("ALRobotPosture", "goToPosture", {Value::string(p->name), Value::real(p->speed)},
                std::move(done), [name](const Value& ok) {
                  return ok.asBool() ? CommandResult::success()
                                     : CommandResult::failure(CommandError::robot_error,
                                                              "posture " + name + " not reached");
                });
  }
  if (const auto* j = std::get_if<Joints>(&c)) {
    return call("ALMotion", "setAngles",
                {Value::strings(j->names), Value::reals(j->angles), Value::real(j->speed)},
                std::move(done));
  }
  if (const auto* w = std::get_if<Walk>(&c)) {
    return call("ALMotion", "moveToward",
                {Value::real(w->x), Value::real(w->y), Value::real(w->theta)}, std::move(done));
  }
  if (std::holds_alternative<Stop>(c)) return call("ALMotion", "stopMove", {}, std::move(done));
  if (std::holds_alternative<Rest>(c)) return call("ALMotion", "rest", {}, std::move(done));
  if (std::holds_alternative<Wake>(c)) return call("ALMotion", "wakeUp", {}, std::move(done));
  if (const auto* l = std::get_if<Leds>(&c)) {
    return call("ALLeds", "fadeRGB",
                {Value::string(l->group), Value::integer(l->rgb), Value::real(l->duration_s)},
                std::move(done));
  }
  done(CommandResult::failure(CommandError::unknown_command, "not supported by naoqi"));
}

void NaoqiBackend::readMemory(std::vector<std::string> keys,
                              std::function<std::string(std::vector<double>)> f, StateDone done) {
  std::vector<Value> names;
  for (const auto& k : keys) names.push_back(Value::string(k));
  auto shared = std::make_shared<StateDone>(std::move(done));
  auto r = client_.call("ALMemory", "getListData", {Value::list(std::move(names))},
                        opt_.call_timeout_ms, [this, shared, f](Result<Value> v) {
                          if (!v) {
                            read_failed_ = read_failed_ || v.error().code == Errc::timeout;
                            return (*shared)(v.error());
                          }
                          std::vector<double> d;
                          for (const Value& x : v->items()) d.push_back(x.asDouble());
                          (*shared)(f(std::move(d)));
                        });
  if (!r) (*shared)(r.error());
}

void NaoqiBackend::read(StateKind k, StateDone done) {
  const char* service = k == StateKind::joints                             ? "ALMotion"
                        : k == StateKind::sonar || k == StateKind::battery ? "ALMemory"
                                                                           : "ALRobotPosture";
  if (std::string why = unavailable(service); !why.empty()) {
    return done(makeError(Errc::not_found, std::move(why)));
  }
  auto shared = std::make_shared<StateDone>(std::move(done));
  auto finish = [this, shared](std::function<std::string(const Value&)> f) {
    return [this, shared, f](Result<Value> v) {
      if (!v) {
        read_failed_ = read_failed_ || v.error().code == Errc::timeout;
        return (*shared)(v.error());
      }
      (*shared)(f(v.value()));
    };
  };
  Result<void> r;
  switch (k) {
    case StateKind::joints:
      r = client_.call("ALMotion", "getAngles",
                       {Value::strings(jointNames()), Value::boolean(true)}, opt_.call_timeout_ms,
                       finish([](const Value& v) {
                         Json::Value o(Json::objectValue);
                         o["angles"] = Json::Value(Json::arrayValue);
                         for (const Value& a : v.items()) o["angles"].append(a.asDouble());
                         return support::writeJson(o);
                       }));
      break;
    case StateKind::sonar:
      return readMemory(
          {"Device/SubDeviceList/US/Left/Sensor/Value",
           "Device/SubDeviceList/US/Right/Sensor/Value"},
          [](std::vector<double> d) {
            Json::Value o(Json::objectValue);
            o["left"] = d.size() > 0 ? d[0] : 0.0;
            o["right"] = d.size() > 1 ? d[1] : 0.0;
            return support::writeJson(o);
          },
          [shared](Result<std::string> s) { (*shared)(std::move(s)); });
    case StateKind::battery:
      return readMemory(
          {"Device/SubDeviceList/Battery/Charge/Sensor/Value"},
          [](std::vector<double> d) {
            Json::Value o(Json::objectValue);
            o["charge"] = d.empty() ? 0.0 : d[0];
            return support::writeJson(o);
          },
          [shared](Result<std::string> s) { (*shared)(std::move(s)); });
    case StateKind::posture:
    case StateKind::fall:
      r = client_.call("ALRobotPosture", "getPosture", {}, opt_.call_timeout_ms,
                       finish([this, k](const Value& v) {
                         const std::string posture = v.asString();
                         const std::string family = postureFamily(posture);
                         Json::Value o(Json::objectValue);
                         if (k == StateKind::posture) {
                           o["posture"] = posture;
                           o["family"] = family;
                         } else {
                           // Lying without having asked for it: the robot fell.
                           o["fallen"] = family.rfind("Lying", 0) == 0 &&
                                         requested_posture_.rfind("Lying", 0) != 0;
                         }
                         return support::writeJson(o);
                       }));
      break;
  }
  if (!r) (*shared)(r.error());
}

Result<void> NaoqiBackend::pump(int timeout_ms, int wake_fd) {
  if (read_failed_) {
    client_.close("the robot stopped answering");
    return makeError(Errc::timeout, "the robot stopped answering");
  }
  auto r = client_.pump(timeout_ms, wake_fd);
  for (auto& [service, why] : client_.takeLost()) missing_[service] = why;
  return r;
}

}  // namespace skr::nao
