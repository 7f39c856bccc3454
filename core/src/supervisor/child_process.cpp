// SPDX-License-Identifier: Apache-2.0
#include "supervisor/child_process.h"

#include <skrobot/runtime/log.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

namespace skr::supervisor {

namespace {

void closeFd(int& fd) noexcept {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

int pidfdOpen(pid_t pid) {
  return static_cast<int>(::syscall(SYS_pidfd_open, pid, 0));
}

std::vector<std::string> reaperArgs(const ChildSpec& s) {
  std::vector<std::string> a{s.reaper.string(),
                             "--name",
                             s.name,
                             "--stop-signal",
                             std::to_string(s.stop_signal),
                             "--grace-ms",
                             std::to_string(s.grace_ms),
                             "--cwd",
                             s.cwd.string()};
  if (s.nice != 0) a.insert(a.end(), {"--nice", std::to_string(s.nice)});
  if (s.memory_bytes != 0) a.insert(a.end(), {"--rlimit-data", std::to_string(s.memory_bytes)});
  if (s.open_files != 0) a.insert(a.end(), {"--rlimit-nofile", std::to_string(s.open_files)});
  a.emplace_back("--");
  a.insert(a.end(), s.command.begin(), s.command.end());
  return a;
}

std::vector<char*> pointers(std::vector<std::string>& v) {
  std::vector<char*> p;
  for (auto& s : v) p.push_back(s.data());
  p.push_back(nullptr);
  return p;
}

}  // namespace

Result<std::unique_ptr<ChildProcess>> ChildProcess::spawn(Loop& loop, const ChildSpec& spec,
                                                          OnOutput on_output, OnExit on_exit) {
  std::unique_ptr<ChildProcess> c(new ChildProcess(loop, std::move(on_output), std::move(on_exit)));
  c->grace_ms_ = spec.grace_ms;
  int control[2] = {-1, -1};
  int out[2] = {-1, -1};
  int err[2] = {-1, -1};
  const auto fail = [&](const std::string& what) {
    const int e = errno;
    for (int* fd : {&control[0], &control[1], &out[0], &out[1], &err[0], &err[1]}) closeFd(*fd);
    return makeError(Errc::io_error, what + ": " + std::strerror(e));
  };
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, control) != 0) return fail("socketpair");
  if (::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0) return fail("pipe");

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_adddup2(&actions, err[1], 2);
  posix_spawn_file_actions_adddup2(&actions, control[1], 3);
  // The reaper ignores what a terminal's Ctrl-C sends the hub's process group: the hub decides.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);
  sigset_t defaults;
  sigfillset(&defaults);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  std::vector<std::string> args = reaperArgs(spec);
  std::vector<std::string> env = spec.env;
  auto argv = pointers(args);
  auto envp = pointers(env);
  pid_t pid = -1;
  const int rc =
      ::posix_spawn(&pid, spec.reaper.c_str(), &actions, &attr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) {
    errno = rc;
    return fail("cannot start " + spec.reaper.string());
  }
  c->reaper_ = pid;
  closeFd(control[1]);
  closeFd(out[1]);
  closeFd(err[1]);
  c->control_ = control[0];
  c->out_[0] = out[0];
  c->out_[1] = err[0];
  c->pidfd_ = pidfdOpen(pid);
  if (c->pidfd_ < 0) return fail("pidfd_open");  // the destructor ends the reaper
  ChildProcess* self = c.get();
  for (int i = 0; i < 2; ++i) {
    auto w = FdWatch::open(loop, c->out_[i], [self, i](unsigned) { self->readOutput(i); });
    if (!w) return w.error();
    c->out_watch_[i] = std::move(w).value();
    c->out_watch_[i].watch(FdWatch::readable);
  }
  auto w = FdWatch::open(loop, c->pidfd_, [self](unsigned) { self->reaped(); });
  if (!w) return w.error();
  c->exit_watch_ = std::move(w).value();
  c->exit_watch_.watch(FdWatch::readable);
  c->escalate_ = Timer(loop, [self, name = spec.name] {
    // The reaper did not end in time: the closed socket makes it kill at once; then SIGKILL.
    log::warn("core.satellites", "SAT-KILL",
              name + ": its reaper did not end in time; " +
                  (self->escalations_ == 0 ? "told to kill at once" : "killed"));
    if (self->escalations_++ == 0) {
      closeFd(self->control_);
      self->escalate_.startIn(1000 * kNsPerMs);
    } else {
      ::kill(self->reaper_, SIGKILL);
    }
  });
  return c;
}

ChildProcess::~ChildProcess() {
  exit_watch_ = {};
  out_watch_[0] = {};
  out_watch_[1] = {};
  closeFd(control_);  // the reaper kills every descendant and exits
  if (!exited_ && reaper_ > 0) {
    // Reaped now if it already went; never waited for on the loop thread (it ends on its own once
    // the socket closed, and init reaps it when the hub is gone).
    int status = 0;
    (void)::waitpid(reaper_, &status, WNOHANG);
  }
  closeFd(pidfd_);
  closeFd(out_[0]);
  closeFd(out_[1]);
}

void ChildProcess::stop() {
  if (exited_ || escalate_.active()) return;
  if (control_ >= 0) {
    const char s = 's';
    (void)!::write(control_, &s, 1);
  }
  escalate_.startIn((static_cast<Nanos>(grace_ms_) + 2000) * kNsPerMs);
}

pid_t ChildProcess::pid() const {
  // The reaper has one child of its own, the satellite (orphans it adopted come later).
  std::ifstream in("/proc/" + std::to_string(reaper_) + "/task/" + std::to_string(reaper_) +
                   "/children");
  pid_t child = 0;
  if (in >> child && child > 0) return child;
  return reaper_;
}

void ChildProcess::readOutput(int i) {
  char buf[16384];
  for (int reads = 0; reads < 16; ++reads) {
    const ssize_t n = ::read(out_[i], buf, sizeof buf);
    if (n > 0) {
      on_output_(i == 1, std::string_view(buf, static_cast<size_t>(n)));
      continue;
    }
    if (n < 0 && (errno == EINTR)) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    out_watch_[i].stop();  // the end, or an error
    closeFd(out_[i]);
    on_output_(i == 1, {});  // the stream ended
    return;
  }
}

void ChildProcess::reaped() {
  int status = 0;
  const pid_t r = ::waitpid(reaper_, &status, WNOHANG);
  if (r == 0) return;
  exit_watch_.stop();
  escalate_.stop();
  exited_ = true;
  // What the satellite wrote before it went: the pipes' write ends are closed now.
  for (int i = 0; i < 2; ++i) {
    if (out_[i] >= 0) readOutput(i);
    if (out_[i] >= 0) {  // still held open by something that escaped: not waited for
      out_watch_[i].stop();
      closeFd(out_[i]);
      on_output_(i == 1, {});
    }
  }
  if (r < 0) status = W_EXITCODE(255, 0);
  on_exit_(status);  // may destroy this
}

}  // namespace skr::supervisor
