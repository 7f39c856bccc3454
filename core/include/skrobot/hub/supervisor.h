// SPDX-License-Identifier: Apache-2.0
// The hub's supervisor of satellites (docs/robot.md): the processes of the config's "satellites",
// started in the order their `after` asks once the modules run, each under skrobot-reaper so that
// no descendant outlives the hub; restarted by their policy with a growing delay and a limit per
// minute; stopped in reverse order. Their output goes line by line into the hub's log (source
// "sat.<name>"). ADMIN sat_ps, sat_start, sat_stop, sat_restart and sat_logs (flowctl ps, start,
// stop, restart, logs) and hub.stats's "satellites" read and drive it.
//
// Log tags (source "core.satellites" unless said): SAT-STARTED, SAT-READY, SAT-NOT-READY (warn:
// not ready within ready_timeout_ms), SAT-EXITED (warn when it was not asked to stop), SAT-RESTART
// (the delay before the next start), SAT-GAVE-UP (error: more starts in a minute than
// max_restarts_per_minute), SAT-SPAWN (error: it cannot be started: no program, no account),
// SAT-STOPPING, SAT-KILL (warn: a reaper that did not end 2 s after the grace period is told to
// kill at once, then killed); and with source "sat.<name>", SAT-STDOUT, SAT-STDERR,
// SAT-LOG-DROPPED. Main loop thread only.
#pragma once

#include <skrobot/hub/hub_config.h>
#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/result.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace skr {

namespace flow {
class FlowServer;
}

struct SupervisorOptions {
  std::filesystem::path reaper;   // skrobot-reaper
  std::filesystem::path bin_dir;  // put first in the satellites' PATH (skrobot-asr, ...)
  // Variables of the hub's environment that its satellites do not get (links' password_env).
  std::vector<std::string> hidden_env;
};

// The PATH a satellite gets: its env's, else bin_dir then the hub's.
[[nodiscard]] std::string satellitePath(const SatelliteEntry& entry,
                                        const std::filesystem::path& bin_dir);
// `program` as given when it has a '/', else the first executable of that name in `path`;
// Errc::not_found says where it was looked for.
[[nodiscard]] Result<std::string> findProgram(const std::string& program, const std::string& path);

class Supervisor {
 public:
  // Registers the ADMIN commands; starts nothing yet. `server` must have started and outlive it.
  Supervisor(Loop& loop, flow::FlowServer& server, std::vector<SatelliteEntry> satellites,
             SupervisorOptions options);
  // Kills what still runs at once (each reaper kills its satellite's descendants).
  ~Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Starts every enabled satellite, each once what its `after` names is up.
  void startAll();
  // Stops them all, those nothing else waits for first; `done` once none runs.
  void stopAll(std::function<void()> done);

  // A reload's changes (skrobot/hub/hub_reload.h): a new satellite starts (if enabled), a
  // removed one stops and goes, a changed one is restarted with its new entry if it runs (else
  // its entry is replaced, and it starts if it was disabled and is enabled now).
  void add(SatelliteEntry entry);
  void remove(const std::string& name);
  void replace(SatelliteEntry entry);

  // One entry per satellite: name, state, pid, uptime_s, restarts, last_exit, account, command,
  // flows [{id, user, client}], channels, next_start_s (while it waits to be restarted).
  [[nodiscard]] flow::Variant list() const;
  [[nodiscard]] Result<flow::Variant> start(const std::string& name);
  [[nodiscard]] Result<flow::Variant> stop(const std::string& name);
  [[nodiscard]] Result<flow::Variant> restart(const std::string& name);
  // {"lines": [{seq, time_ms, stream, text}], "last": seq, "not_logged": n}: up to `max` lines
  // after `after`.
  [[nodiscard]] Result<flow::Variant> logs(const std::string& name, uint64_t after,
                                           size_t max) const;

  struct Sat;

 private:
  Sat* find(const std::string& name) const;
  void evaluate();
  [[nodiscard]] bool dependenciesUp(const Sat& s) const;
  void launch(Sat& s);
  void exited(Sat& s, int status);
  void becameReady(Sat& s, const std::string& how);
  void poll();
  void stopSome();
  void forgetRemoved();
  std::vector<std::string> environment(const Sat& s, const std::string& password) const;

  Loop& loop_;
  flow::FlowServer& server_;
  SupervisorOptions opt_;
  std::vector<std::unique_ptr<Sat>> sats_;  // config order
  std::unique_ptr<struct SupervisorTimers> timers_;
  std::function<void()> stopped_;  // stopAll's `done`
  bool stopping_all_ = false;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);  // for the removals posted
};

}  // namespace skr
