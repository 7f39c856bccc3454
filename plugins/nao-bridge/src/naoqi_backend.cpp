#include "backends.h"

#include <skrobot/support/json.hpp>

#include <json/value.h>

#include <cstdio>

namespace skr::nao {
namespace {

using qi::Value;

CommandResult fromError(const Error& e) {
  if (e.code == Errc::closed || e.code == Errc::io_error) {
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
  auto r = client_.connect(opt_.client);
  if (!r) return r;
  // Look up every service the bridge uses now, so that a robot without one (or with one that
  // cannot be reached) is reported at once, not at the first command.
  for (const char* s : kServices) {
    auto found = client_.resolve(s);
    if (!found) {
      const std::string why =
          std::string("NAOqi service ") + s + " unavailable: " + found.error().message;
      client_.close(why);
      return makeError(found.error().code, why);
    }
  }
  return {};
}

void NaoqiBackend::call(const std::string& service, const std::string& method,
                        std::vector<Value> args, Done done,
                        std::function<CommandResult(const Value&)> check) {
  auto shared = std::make_shared<Done>(std::move(done));
  auto r = client_.call(service, method, std::move(args), opt_.motion_timeout_ms,
                        [shared, check](Result<Value> v) {
                          if (!v) {
                            (*shared)(fromError(v.error()));
                          } else {
                            (*shared)(check ? check(v.value()) : CommandResult::success());
                          }
                        });
  if (!r) (*shared)(fromError(r.error()));
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
  return client_.pump(timeout_ms, wake_fd);
}

}  // namespace skr::nao
