// SPDX-License-Identifier: Apache-2.0
// One run of a supervised satellite: skrobot-reaper (core/app/reaper.cpp) started with
// posix_spawn, and the satellite under it. The reaper's end is watched through a pidfd; its
// standard output and error (the satellite's) are read as they come; a socket whose other end
// only the hub holds tells the reaper to stop the satellite ('s'), and its closing (the hub
// exited, however) makes the reaper kill every descendant. Loop thread only.
#pragma once

#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/loop_handles.h>
#include <skrobot/runtime/result.h>

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace skr::supervisor {

struct ChildSpec {
  std::filesystem::path reaper;      // skrobot-reaper
  std::string name;                  // the satellite's
  std::vector<std::string> command;  // program (a path) and arguments
  std::vector<std::string> env;      // "NAME=value", the child's whole environment
  std::filesystem::path cwd;
  int stop_signal = 15;
  uint32_t grace_ms = 5000;
  uint64_t memory_bytes = 0;  // 0: no limit
  uint32_t open_files = 0;    // 0: the hub's
  int nice = 0;
};

class ChildProcess {
 public:
  // err: stderr; empty bytes: that stream ended.
  using OnOutput = std::function<void(bool err, std::string_view bytes)>;
  using OnExit = std::function<void(int wait_status)>;  // the satellite's, as waitpid gives it

  // Starts the reaper, which starts the satellite. `on_output` gets what it writes (never after
  // `on_exit`, which comes once, after its output was read to the end).
  [[nodiscard]] static Result<std::unique_ptr<ChildProcess>> spawn(Loop& loop,
                                                                   const ChildSpec& spec,
                                                                   OnOutput on_output,
                                                                   OnExit on_exit);
  // Closes the control socket: the reaper kills the satellite and its descendants at once.
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // The stop signal to the satellite's process group, SIGKILL to every descendant after the
  // grace period (the reaper's); should the reaper not exit 2 s after that, it is told to kill
  // at once, then killed.
  void stop();
  // The satellite's pid (the reaper's child), or the reaper's until it is known.
  [[nodiscard]] pid_t pid() const;
  [[nodiscard]] pid_t reaperPid() const noexcept { return reaper_; }

 private:
  ChildProcess(Loop& loop, OnOutput on_output, OnExit on_exit)
      : loop_(loop), on_output_(std::move(on_output)), on_exit_(std::move(on_exit)) {}
  void readOutput(int index);
  void reaped();

  Loop& loop_;
  OnOutput on_output_;
  OnExit on_exit_;
  pid_t reaper_ = -1;
  int pidfd_ = -1;
  int control_ = -1;
  int out_[2] = {-1, -1};  // stdout, stderr: the hub's read ends
  FdWatch exit_watch_;
  FdWatch out_watch_[2];
  Timer escalate_;
  int escalations_ = 0;
  uint32_t grace_ms_ = 0;
  bool exited_ = false;
};

}  // namespace skr::supervisor
