// SPDX-License-Identifier: Apache-2.0
// skrobot-reaper (core/app/reaper.cpp) as the hub runs it: spawned with fd 3 = one end of a
// socketpair the test holds, output to pipes the test reads. Exit statuses, graceful stops, the
// hub's death, processes left behind, and the limits it applies to the program.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <optional>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// One reaper; the destructor closes the control socket (a working reaper then kills everything)
// and SIGKILLs a reaper that did not exit within 3 s.
struct Reaper {
  pid_t pid = -1;
  int control = -1;  // the hub's end of the socketpair
  int out = -1;      // the program's stdout
  int err = -1;      // the program's and the reaper's stderr
  std::string out_buf;

  Reaper() = default;
  Reaper(const Reaper&) = delete;
  Reaper& operator=(const Reaper&) = delete;
  ~Reaper();

  // The status within timeout_ms, polled every 10 ms; nullopt when still running.
  std::optional<int> wait(int timeout_ms) {
    const auto deadline = Clock::now() + milliseconds(timeout_ms);
    for (;;) {
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) == pid) {
        pid = -1;
        return status;
      }
      if (Clock::now() >= deadline) return std::nullopt;
      std::this_thread::sleep_for(milliseconds(10));
    }
  }

  // One line of stdout (without '\n'), or "" when none came within timeout_ms.
  std::string readLine(int timeout_ms) {
    const auto deadline = Clock::now() + milliseconds(timeout_ms);
    for (;;) {
      const size_t nl = out_buf.find('\n');
      if (nl != std::string::npos) {
        std::string line = out_buf.substr(0, nl);
        out_buf.erase(0, nl + 1);
        return line;
      }
      const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
      pollfd p{out, POLLIN, 0};
      if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0) return "";
      char buf[256];
      const ssize_t n = read(out, buf, sizeof buf);
      if (n <= 0) return "";
      out_buf.append(buf, static_cast<size_t>(n));
    }
  }

  // Everything on stderr until EOF (every writer gone) or timeout_ms.
  std::string readErr(int timeout_ms) {
    std::string text;
    const auto deadline = Clock::now() + milliseconds(timeout_ms);
    for (;;) {
      const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
      pollfd p{err, POLLIN, 0};
      if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0) return text;
      char buf[256];
      const ssize_t n = read(err, buf, sizeof buf);
      if (n <= 0) return text;
      text.append(buf, static_cast<size_t>(n));
    }
  }
};

Reaper::~Reaper() {
  if (control >= 0) close(control);
  if (pid > 0 && !wait(3000)) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
  }
  if (out >= 0) close(out);
  if (err >= 0) close(err);
}

// Spawns the reaper with `args` (its options, "--", the program) as the hub does.
void start(Reaper& r, const std::vector<std::string>& args) {
  int out[2], err[2], sock[2];
  ASSERT_EQ(pipe2(out, O_CLOEXEC), 0);
  ASSERT_EQ(pipe2(err, O_CLOEXEC), 0);
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sock), 0);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&fa, out[1], 1);
  posix_spawn_file_actions_adddup2(&fa, err[1], 2);
  posix_spawn_file_actions_adddup2(&fa, sock[1], 3);  // dup2 clears CLOEXEC on fd 3
  std::vector<char*> argv{const_cast<char*>(SKROBOT_REAPER_BIN)};
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const int rc = posix_spawn(&r.pid, SKROBOT_REAPER_BIN, &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  close(out[1]);
  close(err[1]);
  close(sock[1]);
  r.out = out[0];
  r.err = err[0];
  r.control = sock[0];
  ASSERT_EQ(rc, 0) << SKROBOT_REAPER_BIN;
}

// True once `pid` no longer exists (reaped, not a zombie), polled for up to timeout_ms.
bool goneWithin(pid_t pid, int timeout_ms) {
  const auto deadline = Clock::now() + milliseconds(timeout_ms);
  while (Clock::now() < deadline) {
    if (kill(pid, 0) != 0 && errno == ESRCH) return true;
    std::this_thread::sleep_for(milliseconds(10));
  }
  return false;
}

// The status of a reaper run to its end (within 3 s), and its stderr.
std::pair<int, std::string> run(const std::vector<std::string>& args) {
  Reaper r;
  start(r, args);
  const auto status = r.wait(3000);
  EXPECT_TRUE(status.has_value()) << "the reaper did not exit";
  return {status.value_or(-1), r.readErr(1000)};
}

bool killedBy(std::optional<int> status, int sig) {
  return status && WIFSIGNALED(*status) && WTERMSIG(*status) == sig;
}

TEST(Reaper, MirrorsExitCodeSignalAndStartFailures) {
  auto [status, err] = run({"--", "sh", "-c", "exit 3"});
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 3) << status;
  std::tie(status, err) = run({"--", "sh", "-c", "kill -USR1 $$"});
  EXPECT_TRUE(killedBy(status, SIGUSR1)) << status;
  std::tie(status, err) = run({"--", "skrobot-no-such-program", "x"});
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 127) << status;
  EXPECT_NE(err.find("skrobot-reaper: skrobot-no-such-program: cannot exec "
                     "skrobot-no-such-program: No such file or directory"),
            std::string::npos)
      << err;
  std::tie(status, err) = run({"--name", "cam", "--cwd", "/nonexistent", "--", "true"});
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 127) << status;
  EXPECT_NE(err.find("skrobot-reaper: cam: cannot chdir to /nonexistent for true: "),
            std::string::npos)
      << err;
}

TEST(Reaper, RejectsBadArguments) {
  for (const auto& args :
       std::vector<std::vector<std::string>>{{"--bogus", "1", "--", "true"},
                                             {"true"},
                                             {"--grace-ms", "1"},
                                             {"--"},
                                             {"--grace-ms", "1x", "--", "true"},
                                             {"--stop-signal", "0", "--", "true"}}) {
    auto [status, err] = run(args);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 125) << args[0] << ": " << status;
    EXPECT_EQ(err.rfind("skrobot-reaper: ", 0), 0u) << err;
  }
}

TEST(Reaper, StopByteSignalsTheGroupThenKillsAfterTheGrace) {
  {  // the group signal ends the background sleep; sh ignores TERM: SIGKILL after 300 ms
    Reaper r;
    start(r, {"--grace-ms", "300", "--", "sh", "-c",
              "sleep 100 & trap '' TERM; echo ready; wait; echo woke; sleep 100"});
    ASSERT_EQ(r.readLine(2000), "ready");
    const auto t0 = Clock::now();
    ASSERT_EQ(write(r.control, "s", 1), 1);
    EXPECT_EQ(r.readLine(1000), "woke") << "the stop signal did not reach the group";
    const auto status = r.wait(3000);
    EXPECT_TRUE(killedBy(status, SIGKILL)) << status.value_or(-1);
    EXPECT_GE(Clock::now() - t0, milliseconds(250)) << "killed before the grace ran out";
  }
  {  // a program that obeys TERM ends at once, well within the grace
    Reaper r;
    start(r, {"--grace-ms", "5000", "--", "sleep", "100"});
    ASSERT_EQ(write(r.control, "xs", 2), 2);  // bytes other than 's' are ignored
    const auto status = r.wait(1500);
    EXPECT_TRUE(killedBy(status, SIGTERM)) << status.value_or(-1);
  }
}

TEST(Reaper, HubDeathKillsEveryDescendant) {
  Reaper r;
  // The grandchild has a session of its own and prints its pid before it becomes `sleep`.
  start(r, {"--", "sh", "-c", "setsid sh -c 'echo $$; exec sleep 1000' & sleep 1000"});
  const pid_t grandchild = std::atoi(r.readLine(2000).c_str());
  ASSERT_GT(grandchild, 1);
  ASSERT_EQ(kill(grandchild, 0), 0);
  close(r.control);  // the hub dies
  r.control = -1;
  const auto status = r.wait(2000);
  EXPECT_TRUE(killedBy(status, SIGKILL)) << status.value_or(-1);  // at once, not gracefully
  EXPECT_TRUE(goneWithin(grandchild, 2000)) << grandchild;
}

TEST(Reaper, StopsWhatTheProgramLeftBehind) {
  Reaper r;
  start(r, {"--name", "leftovers", "--grace-ms", "2000", "--", "sh", "-c",
            "sleep 1000 & echo $!; exit 0"});
  const pid_t background = std::atoi(r.readLine(2000).c_str());
  ASSERT_GT(background, 1);
  const auto status = r.wait(1500);
  ASSERT_TRUE(status.has_value()) << "the reaper did not exit";
  EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 0) << *status;
  EXPECT_TRUE(goneWithin(background, 2000)) << background;
  const std::string err = r.readErr(1000);
  EXPECT_NE(err.find("skrobot-reaper: leftovers: stopped 1 processes left behind"),
            std::string::npos)
      << err;
}

TEST(Reaper, AppliesSessionLimitsCwdAndNiceness) {
  errno = 0;
  const int nice_now = getpriority(PRIO_PROCESS, 0);
  ASSERT_EQ(errno, 0);
  Reaper r;
  start(r, {"--rlimit-nofile", "64", "--rlimit-data", "1073741824", "--cwd", "/tmp", "--nice", "5",
            "--", "sh", "-c",
            "echo $$ $(cut -d' ' -f6 /proc/$$/stat); ulimit -n; ulimit -d; pwd; nice"});
  const std::string session = r.readLine(2000);  // "PID SID": a session leader
  EXPECT_EQ(session.substr(0, session.find(' ')), session.substr(session.find(' ') + 1));
  EXPECT_EQ(r.readLine(2000), "64");
  EXPECT_EQ(r.readLine(2000), "1048576");  // KiB
  EXPECT_EQ(r.readLine(2000), "/tmp");
  EXPECT_EQ(r.readLine(2000), std::to_string(std::min(19, nice_now + 5)));
  const auto status = r.wait(2000);
  EXPECT_TRUE(status && WIFEXITED(*status) && WEXITSTATUS(*status) == 0) << status.value_or(-1);
}

TEST(Reaper, SigtermIsAGracefulStop) {
  Reaper r;
  start(r, {"--", "sh", "-c", "echo ready; exec sleep 100"});
  ASSERT_EQ(r.readLine(2000), "ready");  // the reaper reads its signals by now
  ASSERT_EQ(kill(r.pid, SIGTERM), 0);
  const auto status = r.wait(1500);
  EXPECT_TRUE(killedBy(status, SIGTERM)) << status.value_or(-1);
}

}  // namespace
