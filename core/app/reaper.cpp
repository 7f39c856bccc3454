// SPDX-License-Identifier: Apache-2.0
// skrobot-reaper: sits between the hub and one supervised satellite process (Linux only).
// The hub spawns it with fd 0 = /dev/null, fds 1 and 2 = the hub's output pipes and fd 3 = the
// read end of a control pipe whose other end only the hub holds. The reaper forks the program in
// a session of its own, is the subreaper of everything it starts, and makes sure that nothing it
// started outlives it: a byte 's' on fd 3 (or SIGTERM) stops the program gracefully, EOF on fd 3
// (the hub died, even by kill -9) kills every descendant at once, and processes left behind by a
// program that exited are stopped too. Its exit status mirrors the program's.
//
//   skrobot-reaper [--stop-signal N] [--grace-ms N] [--nice N] [--rlimit-data BYTES]
//                  [--rlimit-nofile N] [--cwd DIR] [--name NAME] -- PROGRAM [ARGS...]
//
// Exit: the program's exit code, or the program's terminating signal raised again; 125 when the
// reaper itself fails (bad arguments, no fd 3, fork); 127 when the program cannot be started
// (setsid, niceness, limits, cwd, exec), with one line on stderr saying why.
#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/signalfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace {

constexpr int kControlFd = 3;
constexpr int kUsageError = 125;
constexpr int kStartError = 127;

struct Options {
  int stop_signal = SIGTERM;
  long long grace_ms = 5000;
  std::optional<int> nice;  // relative to the reaper's niceness, as nice(1)
  std::optional<rlim_t> rlimit_data;
  std::optional<rlim_t> rlimit_nofile;
  const char* cwd = nullptr;
  const char* name = nullptr;  // in messages; PROGRAM when absent
  char** argv = nullptr;       // PROGRAM [ARGS...], null-terminated
};

enum class Phase { kRunning, kStopping, kLeftovers };

struct State {
  Options opt;
  rlimit core_limit{};  // the hub's RLIMIT_CORE, given back to the program
  int sfd = -1;         // signalfd of SIGCHLD, SIGTERM, SIGINT, SIGHUP, SIGQUIT
  pid_t child = -1;
  bool child_done = false;
  int child_status = 0;
  Phase phase = Phase::kRunning;
  long long deadline_ms = -1;  // end of the running grace period, -1 when none
};

long long nowMs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1000LL + ts.tv_nsec / 1000000;
}

// The reaper's own failures: one line on stderr, exit 125.
[[noreturn]] void fail(const char* why, const char* arg) {
  std::fprintf(stderr, "skrobot-reaper: %s%s\n", why, arg ? arg : "");
  std::exit(kUsageError);
}

[[noreturn]] void usage(const char* why, const char* arg) {
  std::fprintf(stderr, "skrobot-reaper: %s%s\n", why, arg ? arg : "");
  std::fprintf(stderr,
               "usage: skrobot-reaper [--stop-signal N] [--grace-ms N] [--nice N] "
               "[--rlimit-data BYTES] [--rlimit-nofile N] [--cwd DIR] [--name NAME] "
               "-- PROGRAM [ARGS...]\n");
  std::exit(kUsageError);
}

// A whole decimal number in [lo, hi], or usage().
long long number(const char* opt, const char* text, long long lo, long long hi) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0' || v < lo || v > hi) {
    usage("bad number for ", (std::string(opt) + ": " + text).c_str());
  }
  return v;
}

Options parseArgs(int argc, char** argv) {
  Options o;
  int i = 1;
  for (; i < argc && std::strcmp(argv[i], "--") != 0; i += 2) {
    const char* opt = argv[i];
    if (i + 1 >= argc) usage("missing value or '--' after ", opt);
    const char* v = argv[i + 1];
    if (!std::strcmp(opt, "--stop-signal")) {
      o.stop_signal = static_cast<int>(number(opt, v, 1, SIGRTMAX));
    } else if (!std::strcmp(opt, "--grace-ms")) {
      o.grace_ms = number(opt, v, 0, 24LL * 3600 * 1000);
    } else if (!std::strcmp(opt, "--nice")) {
      o.nice = static_cast<int>(number(opt, v, -40, 40));
    } else if (!std::strcmp(opt, "--rlimit-data")) {
      o.rlimit_data = static_cast<rlim_t>(number(opt, v, 0, LLONG_MAX));
    } else if (!std::strcmp(opt, "--rlimit-nofile")) {
      o.rlimit_nofile = static_cast<rlim_t>(number(opt, v, 0, INT_MAX));
    } else if (!std::strcmp(opt, "--cwd")) {
      o.cwd = v;
    } else if (!std::strcmp(opt, "--name")) {
      o.name = v;
    } else {
      usage("unknown option ", opt);
    }
  }
  if (i >= argc) usage("missing '--' before PROGRAM", nullptr);
  if (i + 1 >= argc) usage("missing PROGRAM after '--'", nullptr);
  o.argv = argv + i + 1;
  if (!o.name) o.name = o.argv[0];
  return o;
}

// Subreaper, no core file of our own, the signals read through a signalfd.
void setUp(State& s) {
  if (fcntl(kControlFd, F_GETFD) < 0) fail("fd 3 (the hub's control pipe) is not open", nullptr);
  if (prctl(PR_SET_CHILD_SUBREAPER, 1) != 0)
    fail("cannot become a subreaper: ", std::strerror(errno));
  getrlimit(RLIMIT_CORE, &s.core_limit);
  const rlimit no_core{0, s.core_limit.rlim_max};
  setrlimit(RLIMIT_CORE, &no_core);
  signal(SIGPIPE, SIG_IGN);  // the hub's pipes may be gone: a failed write, not our death
  sigset_t set;
  sigemptyset(&set);
  for (int sig : {SIGCHLD, SIGTERM, SIGINT, SIGHUP, SIGQUIT}) sigaddset(&set, sig);
  sigprocmask(SIG_BLOCK, &set, nullptr);
  s.sfd = signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK);
  if (s.sfd < 0) fail("cannot create a signalfd: ", std::strerror(errno));
}

[[noreturn]] void startFailed(const Options& o, const char* what) {
  std::fprintf(stderr, "skrobot-reaper: %s: cannot %s %s: %s\n", o.name, what, o.argv[0],
               std::strerror(errno));
  _exit(kStartError);
}

// In the forked child: its own session, default signals, niceness, limits, cwd, then exec.
[[noreturn]] void execChild(const State& s) {
  const Options& o = s.opt;
  if (setsid() < 0) startFailed(o, "setsid for");
  for (int sig = 1; sig < NSIG; ++sig) signal(sig, SIG_DFL);  // fails harmlessly for KILL, STOP
  sigset_t empty;
  sigemptyset(&empty);
  sigprocmask(SIG_SETMASK, &empty, nullptr);
  setrlimit(RLIMIT_CORE, &s.core_limit);
  if (o.nice) {
    errno = 0;
    const int current = getpriority(PRIO_PROCESS, 0);
    if (errno != 0 || setpriority(PRIO_PROCESS, 0, current + *o.nice) != 0) {
      startFailed(o, "set the niceness of");
    }
  }
  const rlimit data{o.rlimit_data.value_or(0), o.rlimit_data.value_or(0)};
  if (o.rlimit_data && setrlimit(RLIMIT_DATA, &data) != 0) startFailed(o, "set RLIMIT_DATA of");
  const rlimit files{o.rlimit_nofile.value_or(0), o.rlimit_nofile.value_or(0)};
  if (o.rlimit_nofile && setrlimit(RLIMIT_NOFILE, &files) != 0) {
    startFailed(o, "set RLIMIT_NOFILE of");
  }
  if (o.cwd && chdir(o.cwd) != 0)
    startFailed(o, (std::string("chdir to ") + o.cwd + " for").c_str());
  if (close_range(kControlFd, ~0U, 0) != 0) {
    for (int fd = kControlFd; fd < 65536; ++fd) close(fd);
  }
  execvp(o.argv[0], o.argv);
  startFailed(o, "exec");
}

void startChild(State& s) {
  s.child = fork();
  if (s.child < 0) fail("cannot fork: ", std::strerror(errno));
  if (s.child == 0) execChild(s);
}

// Sends sig to every process whose parent chain reaches the reaper (found in /proc); returns how
// many of them were alive (zombies are signalled but not counted).
int signalDescendants(int sig) {
  struct Proc {
    pid_t ppid;
    bool zombie;
  };
  std::unordered_map<pid_t, Proc> procs;
  if (DIR* proc = opendir("/proc")) {
    while (dirent* e = readdir(proc)) {
      char* end = nullptr;
      const long pid = std::strtol(e->d_name, &end, 10);
      if (end == e->d_name || *end != '\0') continue;
      char path[64], buf[1024];
      std::snprintf(path, sizeof path, "/proc/%ld/stat", pid);
      FILE* f = std::fopen(path, "re");
      if (!f) continue;  // it exited meanwhile
      const size_t n = std::fread(buf, 1, sizeof buf - 1, f);
      std::fclose(f);
      buf[n] = '\0';
      // "pid (comm) state ppid ...": comm may hold spaces and ')', so parse after the last ')'.
      const char* rparen = std::strrchr(buf, ')');
      char state = 0;
      int ppid = 0;
      if (!rparen || std::sscanf(rparen + 1, " %c %d", &state, &ppid) != 2) continue;
      procs[pid] = {ppid, state == 'Z'};
    }
    closedir(proc);
  }
  // Parents first: a shell killed before its child cannot report that child's death as its own
  // exit code.
  const pid_t self = getpid();
  std::vector<std::pair<int, pid_t>> found;  // (depth below the reaper, pid)
  for (const auto& [pid, proc] : procs) {
    pid_t up = proc.ppid;
    int depth = 0;
    for (; up > 1 && up != self && depth < 4096; ++depth) {
      const auto it = procs.find(up);
      up = it == procs.end() ? 0 : it->second.ppid;
    }
    if (up == self) found.emplace_back(depth, pid);
  }
  std::sort(found.begin(), found.end());
  int alive = 0;
  for (const auto& [depth, pid] : found) {
    if (kill(pid, sig) == 0 && !procs[pid].zombie) ++alive;
  }
  return alive;
}

void noteExit(State& s, pid_t pid, int status) {
  if (pid != s.child) return;
  s.child_done = true;
  s.child_status = status;
}

// Reaps every child that has exited; returns false once the reaper has no children left.
bool reapChildren(State& s) {
  for (;;) {
    int status = 0;
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid > 0) {
      noteExit(s, pid, status);
    } else if (pid == 0) {
      return true;
    } else if (errno != EINTR) {
      return false;  // ECHILD
    }
  }
}

// SIGKILL every descendant until none is left. Orphaned grandchildren become our children (we
// are their subreaper), so kill, reap and scan again until waitpid says ECHILD.
void killEverything(State& s) {
  for (;;) {
    signalDescendants(SIGKILL);
    int status = 0;
    const pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0 && errno == EINTR) continue;
    if (pid < 0) return;
    noteExit(s, pid, status);
    if (!reapChildren(s)) return;
  }
}

// Mirrors the program's end: its exit code, or its signal raised again (no core: RLIMIT_CORE 0).
[[noreturn]] void exitLike(int status) {
  if (WIFEXITED(status)) _exit(WEXITSTATUS(status));
  const int sig = WIFSIGNALED(status) ? WTERMSIG(status) : SIGKILL;
  signal(sig, SIG_DFL);
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, sig);
  raise(sig);
  sigprocmask(SIG_UNBLOCK, &set, nullptr);
  _exit(128 + sig);  // a signal whose default action is to ignore it
}

// 's' or SIGTERM: the stop signal to the program's process group, SIGKILL after the grace.
void beginStop(State& s) {
  if (s.phase != Phase::kRunning || s.child_done) return;
  // Before the child's setsid() there is no such group yet: signal the child itself.
  if (kill(-s.child, s.opt.stop_signal) != 0) kill(s.child, s.opt.stop_signal);
  s.phase = Phase::kStopping;
  s.deadline_ms = nowMs() + s.opt.grace_ms;
}

// The program has exited: SIGTERM to what it left behind, SIGKILL after the grace.
void beginLeftovers(State& s) {
  s.phase = Phase::kLeftovers;
  s.deadline_ms = nowMs() + s.opt.grace_ms;
  const int left = signalDescendants(SIGTERM);
  if (left > 0) {
    std::fprintf(stderr, "skrobot-reaper: %s: stopped %d processes left behind\n", s.opt.name,
                 left);
  }
}

void readSignals(State& s) {
  signalfd_siginfo info{};
  while (read(s.sfd, &info, sizeof info) == sizeof info) {
    if (info.ssi_signo == SIGTERM) beginStop(s);
    // SIGCHLD: reaped below; SIGINT, SIGHUP, SIGQUIT: the hub decides, not us.
  }
}

// Returns false when the hub is gone (EOF or an error on fd 3).
bool readControl(State& s) {
  char buf[64];
  const ssize_t n = read(kControlFd, buf, sizeof buf);
  if (n < 0 && (errno == EINTR || errno == EAGAIN)) return true;
  if (n <= 0) return false;
  for (ssize_t i = 0; i < n; ++i) {
    if (buf[i] == 's') beginStop(s);
  }
  return true;
}

[[noreturn]] void supervise(State& s) {
  for (;;) {
    pollfd fds[2] = {{s.sfd, POLLIN, 0}, {kControlFd, POLLIN, 0}};
    int timeout_ms = -1;  // no grace period running: sleep until something happens
    if (s.deadline_ms >= 0) timeout_ms = static_cast<int>(std::max(0LL, s.deadline_ms - nowMs()));
    if (poll(fds, 2, timeout_ms) < 0 && errno != EINTR) {
      killEverything(s);
      exitLike(s.child_status);
    }
    if (fds[0].revents) readSignals(s);
    if (fds[1].revents && !readControl(s)) {
      killEverything(s);  // the hub died: nobody may outlive it
      exitLike(s.child_status);
    }
    const bool children = reapChildren(s);
    if (s.child_done && s.phase != Phase::kLeftovers) beginLeftovers(s);
    if (s.phase == Phase::kLeftovers && !children) exitLike(s.child_status);
    if (s.deadline_ms >= 0 && nowMs() >= s.deadline_ms) {
      killEverything(s);  // reaps the program too
      exitLike(s.child_status);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  State s;
  s.opt = parseArgs(argc, argv);
  setUp(s);
  startChild(s);
  supervise(s);
}
