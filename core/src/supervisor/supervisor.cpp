// SPDX-License-Identifier: Apache-2.0
// The supervisor of satellites (skrobot/hub/supervisor.h): each satellite's states, its start
// order, its restarts, its stop, and the ADMIN commands that show and drive them.
#include <skrobot/hub/supervisor.h>

#include "families/admin/admin_args.h"
#include "supervisor/child_process.h"
#include "supervisor/output_log.h"

#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop_handles.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <map>
#include <optional>
#include <set>

extern char** environ;

namespace skr {

using flow::Variant;

namespace {

constexpr std::string_view kLogSource = "core.satellites";
// A run at least this long was healthy: the next failure's delay starts again from backoff_ms.
constexpr Nanos kHealthyRunNs = 10 * kNsPerSec;
constexpr Nanos kMinuteNs = 60 * kNsPerSec;
constexpr Nanos kPollNs = 100 * kNsPerMs;

enum class State { waiting, starting, running, stopping, backoff, stopped, failed };

std::string_view stateName(State s) {
  switch (s) {
    case State::waiting:
      return "waiting";
    case State::starting:
      return "starting";
    case State::running:
      return "running";
    case State::stopping:
      return "stopping";
    case State::backoff:
      return "backoff";
    case State::stopped:
      return "stopped";
    case State::failed:
      return "failed";
  }
  return "?";
}

std::string describeExit(int status) {
  if (WIFEXITED(status)) {
    const int code = WEXITSTATUS(status);
    if (code == 127) return "exit 127 (its program could not be run)";
    return "exit " + std::to_string(code);
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const char* name = sigabbrev_np(sig);
    return "signal " + std::to_string(sig) +
           (name != nullptr ? " (SIG" + std::string(name) + ")" : "");
  }
  return "status " + std::to_string(status);
}

// The user a satellite logs in as: its account, else its own name.
const std::string& userOf(const SatelliteEntry& e) {
  return e.account.empty() ? e.name : e.account;
}

bool executable(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(path.c_str(), X_OK) == 0;
}

}  // namespace

Result<std::string> findProgram(const std::string& program, const std::string& path) {
  if (program.find('/') != std::string::npos) {
    if (executable(program)) return program;
    return makeError(Errc::not_found, "no program " + program + " (or not executable)");
  }
  for (size_t at = 0; at <= path.size();) {
    const size_t colon = std::min(path.find(':', at), path.size());
    const std::string dir = path.substr(at, colon - at);
    if (!dir.empty() && executable(dir + "/" + program)) return dir + "/" + program;
    at = colon + 1;
  }
  return makeError(Errc::not_found, "no program " + program + " in its PATH (" + path + ")");
}

std::string satellitePath(const SatelliteEntry& e, const std::filesystem::path& bin_dir) {
  for (const auto& [key, value] : e.env) {
    if (key == "PATH") return value;
  }
  const char* hub = std::getenv("PATH");
  const std::string path = hub != nullptr ? hub : "/usr/local/bin:/usr/bin:/bin";
  return bin_dir.empty() ? path : bin_dir.string() + ":" + path;
}

struct Supervisor::Sat {
  explicit Sat(SatelliteEntry entry)
      : e(std::move(entry)), log("sat." + e.name, e.log_lines_per_second) {}
  SatelliteEntry e;
  State state = State::stopped;
  bool wanted = false;                 // it should run: started, and not stopped since
  bool restart_after_stop = false;     // flowctl restart: start again once it exited
  bool removed = false;                // a reload took it out: it goes once it exited
  std::optional<SatelliteEntry> next;  // a reload changed it: its entry from its next start
  std::unique_ptr<supervisor::ChildProcess> child;
  supervisor::OutputLog log;
  Timer timer;  // the next start (backoff), or the readiness warning (starting)
  Nanos started_at = 0, next_start = 0;
  uint32_t restarts = 0;
  uint32_t failures = 0;     // runs in a row that failed within kHealthyRunNs
  std::deque<Nanos> starts;  // those of the last minute
  std::string last_exit;
  std::string password;  // this run's
};

struct SupervisorTimers {
  Timer poll;    // channels waited for (after, ready)
  Timer second;  // the output logs' seconds
};

Supervisor::Supervisor(Loop& loop, flow::FlowServer& server, std::vector<SatelliteEntry> satellites,
                       SupervisorOptions options)
    : loop_(loop),
      server_(server),
      opt_(std::move(options)),
      timers_(std::make_unique<SupervisorTimers>()) {
  for (auto& e : satellites) sats_.push_back(std::make_unique<Sat>(std::move(e)));
  timers_->poll = Timer(loop_, [this] { poll(); });
  timers_->second = Timer(loop_, [this] {
    for (auto& s : sats_) s->log.everySecond();
  });
  if (!sats_.empty()) timers_->second.startEvery(kNsPerSec);
  server_.onSatelliteLogin([this](const std::string& name, uint32_t) {
    Sat* s = find(name);
    if (s != nullptr && s->state == State::starting && s->e.ready == "login") {
      becameReady(*s, "logged in");
    }
  });
  const auto named = [this](Result<Variant> (Supervisor::*fn)(const std::string&)) {
    return [this, fn](const Variant& args, flow::FlowServer::AdminAnswer answer) {
      auto name = flow::adminString(args, "name");
      answer(name ? (this->*fn)(*name) : Result<Variant>(name.error()));
    };
  };
  server_.addAdminCommand(
      "sat_ps", [this](const Variant&, flow::FlowServer::AdminAnswer answer) { answer(list()); });
  server_.addAdminCommand("sat_start", named(&Supervisor::start));
  server_.addAdminCommand("sat_stop", named(&Supervisor::stop));
  server_.addAdminCommand("sat_restart", named(&Supervisor::restart));
  server_.addAdminCommand(
      "sat_logs", [this](const Variant& args, flow::FlowServer::AdminAnswer answer) {
        auto name = flow::adminString(args, "name");
        if (!name) return answer(name.error());
        const auto lines_arg = flow::adminInt(args, "lines");
        const auto after_arg = flow::adminInt(args, "after");
        const int64_t lines = lines_arg ? *lines_arg : 100;
        answer(logs(
            *name, static_cast<uint64_t>(std::max<int64_t>(0, after_arg ? *after_arg : 0)),
            static_cast<size_t>(std::clamp<int64_t>(lines, 1, supervisor::OutputLog::kMaxLines))));
      });
}

Supervisor::~Supervisor() {
  for (const char* c : {"sat_ps", "sat_start", "sat_stop", "sat_restart", "sat_logs"}) {
    server_.removeAdminCommand(c);
  }
  server_.onSatelliteLogin(nullptr);
  timers_.reset();
  for (auto& s : sats_) {
    s->timer = {};
    s->child.reset();  // the reaper kills its satellite and what it started
    if (!s->password.empty()) server_.removeSatellitePassword(userOf(s->e), s->password);
  }
}

Supervisor::Sat* Supervisor::find(const std::string& name) const {
  for (const auto& s : sats_) {
    if (s->e.name == name) return s.get();
  }
  return nullptr;
}

void Supervisor::startAll() {
  for (auto& s : sats_) {
    if (!s->e.enabled) {
      log::info(kLogSource, "SAT-DISABLED", s->e.name + " is disabled (" + s->e.json_path + ")");
      continue;
    }
    s->wanted = true;
    s->state = State::waiting;
  }
  evaluate();
}

bool Supervisor::dependenciesUp(const Sat& s) const {
  for (const std::string& a : s.e.after) {
    if (a.find('.') != std::string::npos) {
      if (!server_.hasChannel(a)) return false;
    } else if (const Sat* d = find(a); d == nullptr || d->state != State::running) {
      return false;
    }
  }
  return true;
}

void Supervisor::evaluate() {
  if (stopping_all_) return;
  for (auto& s : sats_) {
    if (s->state == State::waiting && s->wanted && dependenciesUp(*s)) launch(*s);
  }
  const bool polling = std::any_of(sats_.begin(), sats_.end(), [](const auto& s) {
    return s->state == State::waiting ||
           (s->state == State::starting && s->e.ready.find('.') != std::string::npos);
  });
  if (polling && !timers_->poll.active()) {
    timers_->poll.startEvery(kPollNs);
  } else if (!polling) {
    timers_->poll.stop();
  }
}

void Supervisor::poll() {
  for (auto& s : sats_) {
    if (s->state == State::starting && s->e.ready.find('.') != std::string::npos &&
        server_.hasChannel(s->e.ready)) {
      becameReady(*s, "channel " + s->e.ready + " is there");
    }
  }
  evaluate();
}

std::vector<std::string> Supervisor::environment(const Sat& s, const std::string& password) const {
  std::map<std::string, std::string> env;
  std::set<std::string> hidden(opt_.hidden_env.begin(), opt_.hidden_env.end());
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const char* eq = std::strchr(*e, '=');
    if (eq == nullptr) continue;
    std::string key(*e, static_cast<size_t>(eq - *e));
    if (hidden.count(key) == 0) env[key] = eq + 1;
  }
  env["PATH"] = satellitePath(s.e, opt_.bin_dir);
  env["ROBOT_ADDRESS"] = server_.options().unix_enabled
                             ? "local:" + server_.unixPath()
                             : "tcp:127.0.0.1:" + std::to_string(server_.tcpPort());
  env["SKROBOT_SATELLITE"] = s.e.name;
  for (const auto& [key, value] : s.e.env) env[key] = value;
  env["ROBOT_USER"] = userOf(s.e);
  env["ROBOT_PASSWORD"] = password;
  std::vector<std::string> out;
  for (const auto& [key, value] : env) out.push_back(key + "=" + value);
  return out;
}

void Supervisor::launch(Sat& s) {
  const Nanos now = monotonicNs();
  const auto refuse = [&](const std::string& why) {
    log::error(kLogSource, "SAT-SPAWN", s.e.name + " cannot be started: " + why);
    s.state = State::failed;
    s.last_exit = why;
  };
  auto p = server_.addSatellitePassword(s.e.account, s.e.name);
  if (!p) return refuse(p.error().message);
  std::string password = std::move(p).value();
  supervisor::ChildSpec spec;
  spec.reaper = opt_.reaper;
  spec.name = s.e.name;
  spec.command = s.e.command;
  spec.env = environment(s, password);
  spec.cwd = s.e.cwd;
  spec.stop_signal = s.e.stop_signal;
  spec.grace_ms = s.e.grace_ms;
  spec.memory_bytes = s.e.memory_bytes;
  spec.open_files = s.e.open_files;
  spec.nice = s.e.nice;
  // The program: a path as given, else the first match in the satellite's PATH.
  std::string path;
  for (const auto& v : spec.env) {
    if (v.rfind("PATH=", 0) == 0) path = v.substr(5);
  }
  auto program = findProgram(spec.command[0], path);
  if (!program) {
    server_.removeSatellitePassword(userOf(s.e), password);
    return refuse(program.error().message);
  }
  spec.command[0] = *program;
  Sat* sp = &s;
  auto child = supervisor::ChildProcess::spawn(
      loop_, spec,
      [sp](bool err, std::string_view bytes) {
        if (bytes.empty()) {
          sp->log.ended(err);
        } else {
          sp->log.received(err, bytes);
        }
      },
      [this, sp](int status) { exited(*sp, status); });
  if (!child) {
    server_.removeSatellitePassword(userOf(s.e), password);
    return refuse(child.error().message);
  }
  s.child = std::move(child).value();
  s.password = std::move(password);
  s.started_at = now;
  while (!s.starts.empty() && now - s.starts.front() > kMinuteNs) s.starts.pop_front();
  s.starts.push_back(now);
  s.state = State::starting;
  log::info(kLogSource, "SAT-STARTED",
            s.e.name + " started (pid " + std::to_string(s.child->pid()) + "): " + spec.command[0] +
                ", as " + userOf(s.e));
  if (s.e.ready == "started") return becameReady(s, "started");
  s.timer = Timer(loop_, [sp] {
    log::warn(kLogSource, "SAT-NOT-READY",
              sp->e.name + " is not ready after " + std::to_string(sp->e.ready_timeout_ms) +
                  " ms (ready: " + sp->e.ready + "); what waits for it goes on waiting");
  });
  s.timer.startIn(static_cast<Nanos>(s.e.ready_timeout_ms) * kNsPerMs);
}

void Supervisor::becameReady(Sat& s, const std::string& how) {
  if (s.state != State::starting) return;
  s.state = State::running;
  s.timer.stop();
  log::info(kLogSource, "SAT-READY", s.e.name + " is up (" + how + ")");
  evaluate();
}

void Supervisor::exited(Sat& s, int status) {
  const Nanos now = monotonicNs();
  const pid_t reaper = s.child ? s.child->reaperPid() : 0;
  s.child.reset();
  if (!s.password.empty()) server_.removeSatellitePassword(userOf(s.e), s.password);
  s.password.clear();
  s.timer.stop();
  s.last_exit = describeExit(status);
  const bool asked = s.state == State::stopping;
  const std::string ran = std::to_string((now - s.started_at) / kNsPerMs) + " ms";
  const std::string line = s.e.name + " (reaper " + std::to_string(reaper) +
                           ") exited: " + s.last_exit + " after " + ran;
  if (s.next) {
    s.e = std::move(*s.next);
    s.next.reset();
    s.log.setRate(s.e.log_lines_per_second);
  }
  if (s.removed) {
    log::info(kLogSource, "SAT-EXITED", line);
    s.state = State::stopped;
    forgetRemoved();
    if (stopping_all_) stopSome();
    return;
  }
  if (asked) {
    log::info(kLogSource, "SAT-EXITED", line);
    s.state = State::stopped;
    if (s.restart_after_stop && !stopping_all_) {
      s.restart_after_stop = false;
      s.state = State::waiting;
      evaluate();
    }
    if (stopping_all_) stopSome();
    return;
  }
  log::warn(kLogSource, "SAT-EXITED", line);
  const bool failure = !(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  const bool again = s.wanted && !stopping_all_ &&
                     (s.e.restart == SatelliteEntry::Restart::always ||
                      (s.e.restart == SatelliteEntry::Restart::on_failure && failure));
  if (!again) {
    s.state = failure ? State::failed : State::stopped;
    if (stopping_all_) stopSome();
    return;
  }
  s.failures = now - s.started_at >= kHealthyRunNs ? 1 : s.failures + 1;
  while (!s.starts.empty() && now - s.starts.front() > kMinuteNs) s.starts.pop_front();
  if (s.starts.size() >= s.e.max_restarts_per_minute) {
    s.state = State::failed;
    log::error(kLogSource, "SAT-GAVE-UP",
               s.e.name + " started " + std::to_string(s.starts.size()) +
                   " times in the last minute (max_restarts_per_minute " +
                   std::to_string(s.e.max_restarts_per_minute) +
                   "): not restarted again; flowctl start " + s.e.name + " tries again");
    return;
  }
  const uint32_t shift = std::min<uint32_t>(s.failures - 1, 20);
  const Nanos delay_ms =
      std::min<Nanos>(s.e.max_backoff_ms, static_cast<Nanos>(s.e.backoff_ms) << shift);
  s.state = State::backoff;
  s.next_start = now + delay_ms * kNsPerMs;
  log::info(kLogSource, "SAT-RESTART",
            s.e.name + " starts again in " + std::to_string(delay_ms) + " ms");
  Sat* sp = &s;
  s.timer = Timer(loop_, [this, sp] {
    sp->state = State::waiting;
    ++sp->restarts;
    evaluate();
  });
  s.timer.startIn(delay_ms * kNsPerMs);
}

void Supervisor::stopAll(std::function<void()> done) {
  stopping_all_ = true;
  stopped_ = std::move(done);
  timers_->poll.stop();
  for (auto& s : sats_) {
    s->wanted = false;
    s->restart_after_stop = false;
    if (s->state == State::waiting || s->state == State::backoff) {
      s->timer.stop();
      s->state = State::stopped;
    }
  }
  stopSome();
}

void Supervisor::stopSome() {
  bool running = false;
  for (auto& s : sats_) {
    if (!s->child) continue;
    running = true;
    if (s->state != State::starting && s->state != State::running) continue;
    // Those that wait for it, or for one of its channels, stop first.
    std::set<std::string> its{s->e.name};
    for (const auto& f : server_.flowsOfSatellite(s->e.name))
      its.insert(f.channels.begin(), f.channels.end());
    const bool needed = std::any_of(sats_.begin(), sats_.end(), [&](const auto& t) {
      return t.get() != s.get() && t->child &&
             std::any_of(t->e.after.begin(), t->e.after.end(),
                         [&](const std::string& a) { return its.count(a) != 0; });
    });
    if (needed) continue;
    s->state = State::stopping;
    log::info(kLogSource, "SAT-STOPPING", s->e.name);
    s->child->stop();
  }
  if (!running && stopped_) {
    auto done = std::move(stopped_);
    stopped_ = nullptr;
    done();
  }
}

void Supervisor::add(SatelliteEntry entry) {
  if (find(entry.name) != nullptr) return replace(std::move(entry));
  sats_.push_back(std::make_unique<Sat>(std::move(entry)));
  Sat& s = *sats_.back();
  if (!timers_->second.active()) timers_->second.startEvery(kNsPerSec);
  log::info(kLogSource, "SAT-ADDED", s.e.name + " (" + s.e.json_path + ")");
  if (!s.e.enabled || stopping_all_) return;
  s.wanted = true;
  s.state = State::waiting;
  evaluate();
}

void Supervisor::remove(const std::string& name) {
  Sat* s = find(name);
  if (s == nullptr) return;
  log::info(kLogSource, "SAT-REMOVED", name);
  s->removed = true;
  s->wanted = false;
  s->restart_after_stop = false;
  s->timer.stop();
  if (s->state == State::starting || s->state == State::running) {
    s->state = State::stopping;
    s->child->stop();
  } else if (!s->child) {
    forgetRemoved();
  }
}

void Supervisor::replace(SatelliteEntry entry) {
  Sat* s = find(entry.name);
  if (s == nullptr) return add(std::move(entry));
  log::info(kLogSource, "SAT-CHANGED", entry.name + " (" + entry.json_path + ")");
  const bool was_enabled = s->e.enabled;
  if (s->child) {
    s->next = std::move(entry);
    if (s->state == State::starting || s->state == State::running) {
      s->restart_after_stop = s->next->enabled;
      s->wanted = s->next->enabled;
      s->state = State::stopping;
      s->child->stop();
    }
    return;
  }
  s->e = std::move(entry);
  s->log.setRate(s->e.log_lines_per_second);
  if (!s->e.enabled) {
    s->timer.stop();
    s->wanted = false;
    s->state = State::stopped;
  } else if (!was_enabled && !stopping_all_) {
    s->wanted = true;
    s->state = State::waiting;
    evaluate();
  }
}

// Removed satellites whose run ended go, once no callback of theirs is running.
void Supervisor::forgetRemoved() {
  loop_.post([this, alive = std::weak_ptr<int>(alive_)] {
    if (alive.expired()) return;
    std::erase_if(sats_, [](const auto& s) { return s->removed && !s->child; });
  });
}

Result<Variant> Supervisor::start(const std::string& name) {
  Sat* s = find(name);
  if (s == nullptr) return makeError(Errc::not_found, "no satellite " + name);
  if (stopping_all_) return makeError(Errc::unsupported, "the hub is stopping");
  if (s->state == State::stopping) {
    s->wanted = true;
    s->restart_after_stop = true;
  } else if (s->state == State::stopped || s->state == State::failed ||
             s->state == State::backoff) {
    s->timer.stop();
    s->wanted = true;
    s->failures = 0;
    s->starts.clear();
    s->state = State::waiting;
    log::info(kLogSource, "SAT-START", name + " asked to start");
    evaluate();
  }
  return Variant(Variant::Map{{"name", name}, {"state", std::string(stateName(s->state))}});
}

Result<Variant> Supervisor::stop(const std::string& name) {
  Sat* s = find(name);
  if (s == nullptr) return makeError(Errc::not_found, "no satellite " + name);
  s->wanted = false;
  s->restart_after_stop = false;
  if (s->state == State::waiting || s->state == State::backoff) {
    s->timer.stop();
    s->state = State::stopped;
  } else if (s->state == State::starting || s->state == State::running) {
    s->state = State::stopping;
    log::info(kLogSource, "SAT-STOPPING", name + " asked to stop");
    s->child->stop();
  }
  evaluate();
  return Variant(Variant::Map{{"name", name}, {"state", std::string(stateName(s->state))}});
}

Result<Variant> Supervisor::restart(const std::string& name) {
  Sat* s = find(name);
  if (s == nullptr) return makeError(Errc::not_found, "no satellite " + name);
  if (stopping_all_) return makeError(Errc::unsupported, "the hub is stopping");
  if (s->state != State::starting && s->state != State::running) return start(name);
  s->wanted = true;
  s->restart_after_stop = true;
  ++s->restarts;
  s->state = State::stopping;
  log::info(kLogSource, "SAT-STOPPING", name + " asked to restart");
  s->child->stop();
  return Variant(Variant::Map{{"name", name}, {"state", std::string(stateName(s->state))}});
}

Variant Supervisor::list() const {
  const Nanos now = monotonicNs();
  Variant::List out;
  for (const auto& s : sats_) {
    Variant::List command;
    for (const auto& c : s->e.command) command.emplace_back(c);
    Variant::List flows;
    Variant::List channels;
    for (const auto& f : server_.flowsOfSatellite(s->e.name)) {
      flows.push_back(
          Variant::Map{{"id", static_cast<int64_t>(f.id)}, {"user", f.user}, {"client", f.client}});
      for (const auto& c : f.channels) channels.emplace_back(c);
    }
    Variant::List waiting_for;
    if (s->state == State::waiting) {
      for (const auto& a : s->e.after) {
        const Sat* d = a.find('.') == std::string::npos ? find(a) : nullptr;
        const bool up = d != nullptr ? d->state == State::running
                                     : a.find('.') != std::string::npos && server_.hasChannel(a);
        if (!up) waiting_for.emplace_back(a);
      }
    }
    Variant::Map m{{"name", s->e.name},
                   {"state", std::string(stateName(s->state))},
                   {"pid", static_cast<int64_t>(s->child ? s->child->pid() : 0)},
                   {"uptime_s", s->child ? static_cast<double>(now - s->started_at) / 1e9 : 0.0},
                   {"restarts", static_cast<int64_t>(s->restarts)},
                   {"last_exit", s->last_exit},
                   {"user", userOf(s->e)},
                   {"command", Variant(std::move(command))},
                   {"flows", Variant(std::move(flows))},
                   {"channels", Variant(std::move(channels))},
                   {"waiting_for", Variant(std::move(waiting_for))},
                   {"log_lines_not_logged", static_cast<int64_t>(s->log.notLogged())}};
    if (s->state == State::backoff) {
      m["next_start_s"] = static_cast<double>(std::max<Nanos>(0, s->next_start - now)) / 1e9;
    }
    out.emplace_back(std::move(m));
  }
  return Variant(std::move(out));
}

Result<Variant> Supervisor::logs(const std::string& name, uint64_t after, size_t max) const {
  const Sat* s = find(name);
  if (s == nullptr) return makeError(Errc::not_found, "no satellite " + name);
  Variant::List lines;
  for (const auto& l : s->log.after(after, max)) {
    lines.push_back(Variant::Map{{"seq", static_cast<int64_t>(l.seq)},
                                 {"time_ms", l.time_ms},
                                 {"stream", l.err ? "stderr" : "stdout"},
                                 {"text", l.text}});
  }
  return Variant(Variant::Map{{"lines", Variant(std::move(lines))},
                              {"last", static_cast<int64_t>(s->log.lastSeq())},
                              {"not_logged", static_cast<int64_t>(s->log.notLogged())}});
}

}  // namespace skr
