// SPDX-License-Identifier: Apache-2.0
// The bridge's robot thread: owns the backend, connects and reconnects it with backoff, looks
// for the parts a connected robot lacks with the same backoff, runs commands in submission
// order and polls the state kinds that are switched on at their rates.
// Its callbacks run on this thread; the module posts what they carry to the hub's loop.
#pragma once

#include "robot_backend.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace skr::nao {

struct WorkerOptions {
  std::array<double, 5> rate_hz = {10, 5, 1, 2, 5};  // by StateKind
  int reconnect_min_ms = 500;
  int reconnect_max_ms = 10000;
};

struct WorkerStatus {
  bool connected = false;
  std::string detail;  // connected: the backend's description; else why not
  // Not connected: when the next attempt is; connected with parts missing: when they are looked
  // for next; else 0.
  int retry_in_ms = 0;
  std::map<std::string, std::string> missing;  // connected: what the robot lacks, with why
};

struct WorkerCallbacks {
  // On connecting, on losing the connection, after each failed attempt, and when what is
  // missing changes or was looked for again.
  std::function<void(const WorkerStatus&)> status;
  std::function<void(StateKind, const std::string& json)> state;
};

class RobotWorker {
 public:
  RobotWorker(std::unique_ptr<RobotBackend> backend, WorkerOptions o, WorkerCallbacks cb);
  ~RobotWorker();  // stops and joins
  RobotWorker(const RobotWorker&) = delete;
  RobotWorker& operator=(const RobotWorker&) = delete;

  void start();
  void stop();  // joins; queued commands fail with not_connected
  // Any thread. `done` runs on the worker thread, exactly once.
  void submit(Command c, RobotBackend::Done done);
  // Any thread. Calls `done(r)` on the worker thread after the commands submitted before it were
  // started: refusals of queued commands keep their place among the results.
  void submitResult(CommandResult r, RobotBackend::Done done);
  // Any thread: poll this kind of state (when someone listens) or not.
  void setStreaming(StateKind k, bool on);

 private:
  struct Job {
    Command command;
    RobotBackend::Done done;
    std::optional<CommandResult> result;  // set: not a command, just report this
  };
  void run();
  void wake();
  std::deque<Job> takeJobs();

  std::unique_ptr<RobotBackend> backend_;
  WorkerOptions opt_;
  WorkerCallbacks cb_;
  std::mutex mu_;
  std::deque<Job> jobs_;
  std::array<std::atomic<bool>, 5> streaming_{};
  std::atomic<bool> stopping_{false};
  int wake_fd_ = -1;
  std::thread thread_;
};

}  // namespace skr::nao
