// SPDX-License-Identifier: Apache-2.0
// Test helpers: a real `skrobot` hub started from a temp config, and child processes (examples,
// flowctl) whose output is captured. Header-only; used by the satellite and flowctl tests.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include "eventually.h"
#include "temp_dir.h"

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace skr::sat::test {

namespace fs = std::filesystem;
using skr::test::TempDir;

inline std::string slurp(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

using skr::test::eventually;

// A child process with stdout+stderr in a file. Killed (SIGKILL) if still running at destruction.
class Child {
 public:
  Child(const std::vector<std::string>& argv, const std::vector<std::string>& env, fs::path output,
        const std::string& stdin_text = {})
      : output_(std::move(output)) {
    int in_pipe[2] = {-1, -1};
    if (pipe(in_pipe) != 0) return;
    pid_ = fork();
    if (pid_ == 0) {
      FILE* out = std::fopen(output_.c_str(), "w");
      dup2(fileno(out), 1);
      dup2(fileno(out), 2);
      dup2(in_pipe[0], 0);
      ::close(in_pipe[1]);
      for (const auto& e : env) putenv(const_cast<char*>(e.c_str()));
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
    ::close(in_pipe[0]);
    if (!stdin_text.empty()) (void)!write(in_pipe[1], stdin_text.data(), stdin_text.size());
    ::close(in_pipe[1]);
  }
  ~Child() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      wait();
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  Child(Child&&) = delete;
  Child& operator=(Child&&) = delete;

  void signal(int sig) const {
    if (pid_ > 0 && !exited_) kill(pid_, sig);
  }
  [[nodiscard]] pid_t pid() const noexcept { return pid_; }
  // Exit code (128 + signal when killed); -1 if it did not exit within timeout_ms.
  int wait(int timeout_ms = 60000) {
    if (exited_) return code_;
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    for (;;) {
      int status = 0;
      const pid_t r = waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        exited_ = true;
        code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        return code_;
      }
      if (std::chrono::steady_clock::now() > end) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  [[nodiscard]] bool running() {
    if (exited_) return false;
    int status = 0;
    const pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      exited_ = true;
      code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    return !exited_;
  }
  [[nodiscard]] std::string output() const { return slurp(output_); }
  [[nodiscard]] bool waitOutput(const std::string& text, int timeout_ms = 20000) const {
    return eventually([&] { return output().find(text) != std::string::npos; }, timeout_ms);
  }

 private:
  fs::path output_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int code_ = -1;
};

// The skrobot executable on a temp config: unique app_name, data in `dir`, the development
// account guest/password, the Unix socket at <dir>/hub.sock.
class HubProcess {
 public:
  // With `tcp_user`, TCP is on too (any free port) and that account exists (password
  // "s3cret-pass"), made with `skrobot user add`. `server_keys` go into the "server" object
  // with TCP, e.g. R"(, "tls": {...})"; `top_keys` go into the document, e.g.
  // R"("sync": {"hub_source": "tick"}, )".
  // `modules` is the config's "modules" array.
  HubProcess(std::string binary, const fs::path& dir, const std::string& tcp_user = {},
             const std::string& server_keys = {}, const std::string& top_keys = {},
             const std::string& modules = "[]")
      : binary_(std::move(binary)), dir_(dir), socket_(dir / "hub.sock") {
    static int counter = 0;
    app_ = "skrobot-sat-" + std::to_string(getpid()) + "-" + std::to_string(++counter);
    if (!tcp_user.empty()) {
      const fs::path users = dir_ / "users.json";
      Child add({binary_, "user", "add", tcp_user, "--users", users.string(), "--password-stdin"},
                {}, dir_ / "user-add.log", "s3cret-pass\n");
      add.wait();
      tcp_ = R"(, "tcp": true, "tcp_port": 0)" + server_keys +
             R"(}, "accounts": {"users_file": ")" + users.string() + R"(", )";
    } else {
      tcp_ = R"(}, "accounts": {)";
    }
    writeConfig(top_keys, modules);
  }

  // Writes the config again with other `top_keys` and `modules` (the rest as made): what a
  // reload (SIGHUP, flowctl reload) then reads.
  void writeConfig(const std::string& top_keys, const std::string& modules) {
    std::ofstream(dir_ / "hub.json") << R"({"app_name": ")" << app_ << R"(",
      "data_dir": ")" << (dir_ / "data").string()
                                     << R"(",
      "server": {"unix_path": ")" << socket_.string()
                                     << R"(")" << tcp_ << R"(
        "dev_account": {"user": "guest", "password": "password"}},
      )" << top_keys << R"("modules": )"
                                     << modules << "}";
  }

  // Starts the hub and waits until it accepts satellites.
  bool start() {
    ++starts_;
    const fs::path log = dir_ / ("hub-" + std::to_string(starts_) + ".log");
    child_ = std::make_unique<Child>(
        std::vector<std::string>{binary_, "--config", (dir_ / "hub.json").string()},
        std::vector<std::string>{}, log);
    return child_->waitOutput("HUB-READY");
  }
  // SIGTERM, and waits for a clean exit.
  int stop() {
    if (!child_) return 0;
    child_->signal(SIGTERM);
    const int code = child_->wait();
    logs_ += child_->output();
    child_.reset();
    return code;
  }
  [[nodiscard]] std::string address() const { return "local:" + socket_.string(); }
  // "tcp:127.0.0.1:<port>" from the hub's FLOW-LISTEN line, or "" without TCP.
  [[nodiscard]] std::string tcpAddress() const {
    const std::string text = log();
    const std::string key = "FLOW-LISTEN TCP ";
    const size_t at = text.rfind(key);
    if (at == std::string::npos) return {};
    return "tcp:" + text.substr(at + key.size(),
                                text.find_first_of(" \n", at + key.size()) - at - key.size());
  }
  // "tls:<host>:<port>" from the hub's FLOW-LISTEN TLS line, or "" without TLS.
  [[nodiscard]] std::string tlsAddress(const std::string& host = "localhost") const {
    const std::string text = log();
    const std::string key = "FLOW-LISTEN TLS ";
    const size_t at = text.rfind(key);
    if (at == std::string::npos) return {};
    const size_t colon = text.find(':', at + key.size());
    const size_t end = text.find_first_of(" \n", colon);
    return "tls:" + host + ":" + text.substr(colon + 1, end - colon - 1);
  }
  [[nodiscard]] const fs::path& socket() const { return socket_; }
  // Waits until the running hub's log has `text`.
  [[nodiscard]] bool waitLog(const std::string& text, int timeout_ms = 20000) const {
    return child_ && child_->waitOutput(text, timeout_ms);
  }
  [[nodiscard]] std::string log() const { return logs_ + (child_ ? child_->output() : ""); }
  // Sends `sig` to the running hub (SIGHUP: a reload).
  void signal(int sig) const {
    if (child_) child_->signal(sig);
  }
  // Sends `sig` to the hub (SIGKILL: a crash) and waits for it to end; its exit code.
  int kill(int sig) {
    if (!child_) return 0;
    child_->signal(sig);
    const int code = child_->wait();
    logs_ += child_->output();
    child_.reset();
    return code;
  }
  [[nodiscard]] pid_t pid() const { return child_ ? child_->pid() : -1; }
  [[nodiscard]] const fs::path& dir() const { return dir_; }
  ~HubProcess() { stop(); }
  HubProcess(const HubProcess&) = delete;
  HubProcess& operator=(const HubProcess&) = delete;
  HubProcess(HubProcess&&) = delete;
  HubProcess& operator=(HubProcess&&) = delete;

 private:
  std::string binary_;
  fs::path dir_;
  fs::path socket_;
  std::string app_;
  std::string tcp_;  // the config's TCP and accounts part
  int starts_ = 0;
  std::unique_ptr<Child> child_;
  std::string logs_;
};

}  // namespace skr::sat::test
