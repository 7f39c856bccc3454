// SPDX-License-Identifier: Apache-2.0
// The two backends: the simulated Nao (always connected) and a real one over NAOqi's qi protocol.
#pragma once

#include "qi_client.h"
#include "robot_backend.h"
#include "sim_robot.h"

#include <cstdint>
#include <map>
#include <memory>
#include <string>

namespace skr::nao {

class SimBackend final : public RobotBackend {
 public:
  explicit SimBackend(SimOptions o);
  Result<void> connect() override { return {}; }
  bool connected() const override { return true; }
  void disconnect(const std::string&) override {}
  void execute(const Command& c, Done done) override;
  void read(StateKind k, StateDone done) override;
  Result<void> pump(int timeout_ms, int wake_fd) override;  // waits, then advances wall time
  std::string describe() const override { return "simulated"; }

 private:
  void advance();
  SimRobot robot_;
  std::int64_t last_ns_;
};

struct NaoqiOptions {
  qi::ClientOptions client;
  int call_timeout_ms = 2000;     // state reads; a late answer means the link is broken
  int motion_timeout_ms = 30000;  // commands, which NAOqi answers when the motion is done
};

class NaoqiBackend final : public RobotBackend {
 public:
  // Every service the bridge calls; connect() looks each one up. One that is missing (or whose
  // connection is lost later) only fails the commands and reads that need it.
  static constexpr const char* kServices[] = {"ALMotion", "ALRobotPosture", "ALTextToSpeech",
                                              "ALMemory", "ALLeds"};

  explicit NaoqiBackend(NaoqiOptions o) : opt_(std::move(o)) {}
  Result<void> connect() override;
  bool connected() const override { return client_.connected(); }
  void disconnect(const std::string& why) override { client_.close(why); }
  void execute(const Command& c, Done done) override;
  void read(StateKind k, StateDone done) override;
  Result<void> pump(int timeout_ms, int wake_fd) override;
  std::string describe() const override;
  std::map<std::string, std::string> missing() const override { return missing_; }
  void retryMissing() override;

 private:
  // "NAOqi service <name> unavailable: <why>" when `service` is missing, else "".
  [[nodiscard]] std::string unavailable(const std::string& service) const;
  void call(const std::string& service, const std::string& method, std::vector<qi::Value> args,
            Done done, std::function<CommandResult(const qi::Value&)> check = {});
  void readMemory(std::vector<std::string> keys, std::function<std::string(std::vector<double>)> f,
                  StateDone done);

  NaoqiOptions opt_;
  qi::QiClient client_;
  std::map<std::string, std::string> missing_;  // service -> why, while connected
  std::string requested_posture_;               // a lying posture asked for is not a fall
  bool read_failed_ = false;  // a state read timed out: drop the link at the next pump
};

}  // namespace skr::nao
