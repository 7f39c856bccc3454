// SPDX-License-Identifier: Apache-2.0
// The skrobot executable as a user runs it: options, config errors, module failures, signals.
#include "temp_dir.h"
#include "test_client.h"

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using skr::test::TempDir;

struct Run {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

std::string slurp(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Starts skrobot with `args`, output to `log`. Returns the pid.
pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    FILE* out = std::fopen(log.c_str(), "w");
    dup2(fileno(out), 1);
    dup2(fileno(out), 2);
    std::vector<char*> argv{const_cast<char*>(SKROBOT_BIN)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(SKROBOT_BIN, argv.data());
    _exit(127);
  }
  return pid;
}

int waitExit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

Run run(const std::vector<std::string>& args) {
  TempDir dir;
  const fs::path log = dir.path() / "out.txt";
  Run r;
  r.exit_code = waitExit(spawn(args, log));
  r.output = slurp(log);
  return r;
}

bool waitFor(const fs::path& log, const std::string& text) {
  for (int i = 0; i < 3000; ++i) {  // up to 30 s on a loaded machine
    if (slurp(log).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

const std::string kDefaultConfig = std::string(SKROBOT_SOURCE_DIR) + "/config/default.json";

TEST(SkrobotCli, VersionAndHelp) {
  auto v = run({"--version"});
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_NE(v.output.find("skrobot " SKROBOT_VERSION), std::string::npos) << v.output;
  auto h = run({"--help"});
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.output.find("--check-config"), std::string::npos);
  auto bad = run({"--frobnicate"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("unknown option '--frobnicate'"), std::string::npos);
}

TEST(SkrobotCli, DefaultConfigChecksOut) {
  auto r = run({"--config", kDefaultConfig, "--check-config"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("websocket-ui"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("is valid"), std::string::npos) << r.output;
}

TEST(SkrobotCli, BadConfigIsRefusedWithPathAndReason) {
  TempDir dir;
  auto cfg = dir.write("bad.json", R"({"loop": {"fast_tick_ms": 0}, "modlues": []})");
  auto r = run({"--config", cfg.string()});
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("$.loop.fast_tick_ms"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("unknown key \"modlues\""), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("HUB-START"), std::string::npos) << "must not start";
}

TEST(SkrobotCli, CheckConfigReportsModulesThatWouldFail) {
  TempDir dir;
  auto cfg = dir.write("cfg.json", R"({"modules": [{"name": "example"}, {"name": "no_such_module"},
      {"path": ")" SKROBOT_TEST_MODULE_DIR R"(/test_abi_major.so"}]})");
  auto r = run({"--config", cfg.string(), "--check-config"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("no_such_module"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("test_abi_major"), std::string::npos) << r.output;
}

TEST(SkrobotCli, CheckConfigLoadsTheTlsFiles) {
  TempDir dir;
  const std::string certs = (dir.path() / "certs").string();
  ASSERT_EQ(std::system(("sh " + std::string(SKROBOT_SOURCE_DIR) +
                         "/tests/support/make_test_certs.sh " + certs + " >/dev/null 2>&1")
                            .c_str()),
            0);
  const auto config = [&](const std::string& cert, const std::string& key) {
    return dir.write("cfg.json", R"({"modules": [], "server": {"tcp": true, "tls": {"cert": ")" +
                                     certs + "/" + cert + R"(", "key": ")" + certs + "/" + key +
                                     R"(", "client_ca": ")" + certs + R"(/ca.pem"}}})");
  };
  auto good = run({"--config", config("hub.pem", "hub.key").string(), "--check-config"});
  EXPECT_EQ(good.exit_code, 0) << good.output;
  EXPECT_NE(good.output.find("(client certificates required)"), std::string::npos) << good.output;
  auto missing = run({"--config", config("nope.pem", "hub.key").string(), "--check-config"});
  EXPECT_EQ(missing.exit_code, 3) << missing.output;
  EXPECT_NE(missing.output.find("server.tls: TLS: certificate " + certs + "/nope.pem"),
            std::string::npos)
      << missing.output;
  auto mismatch = run({"--config", config("hub.pem", "client.key").string(), "--check-config"});
  EXPECT_EQ(mismatch.exit_code, 3) << mismatch.output;
  EXPECT_NE(mismatch.output.find("client.key"), std::string::npos) << mismatch.output;
}

TEST(SkrobotCli, CheckConfigReportsModuleConfigErrorsWithTheirPaths) {
  TempDir dir;
  auto cfg = dir.write("cfg.json", R"({"modules": [
      {"name": "example", "config": {"period_ms": 0, "greting": "hi"}},
      {"path": ")" SKROBOT_TEST_MODULE_DIR R"(/test_config_keys.so", "config": {"count": "3"}}]})");
  auto r = run({"--config", cfg.string(), "--check-config"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("MODULE-CONFIG $.modules[0].config.period_ms: must be >= 1, got 0"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("MODULE-CONFIG $.modules[0].config.greting: unknown key (did you mean "
                          "\"greeting\"?)"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("MODULE-CONFIG $.modules[1].config.count: expected integer, got string"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("MODULE-CONFIG $.modules[1].config.input: required key missing"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("2 enabled modules would fail"), std::string::npos) << r.output;
  // Checked without starting anything: no module log line.
  EXPECT_EQ(r.output.find("CONFIG-KEYS-INIT"), std::string::npos) << r.output;
}

// A link's password variable is the hub's environment's business: a check in another shell says
// it will be needed; a start without it is refused with the path and the variable.
TEST(SkrobotCli, CheckConfigNotesAnUnsetPasswordVariableWhereAStartRefusesIt) {
  TempDir dir;
  ::unsetenv("SKROBOT_TEST_UNSET_LINK_PW");
  auto cfg = dir.write("cfg.json", R"({"app_name": "cli-link-)" + std::to_string(::getpid()) +
                                       R"(", "hub_name": "here", "links": [{"name": "base",
      "address": "local:/tmp/nowhere", "user": "guest",
      "password_env": "SKROBOT_TEST_UNSET_LINK_PW"}]})");
  auto check = run({"--config", cfg.string(), "--check-config"});
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("$.links[0].password_env: the variable SKROBOT_TEST_UNSET_LINK_PW is "
                              "not set here: the hub's environment must set it at start"),
            std::string::npos)
      << check.output;
  auto start = run({"--config", cfg.string()});
  EXPECT_NE(start.exit_code, 0) << start.output;
  EXPECT_NE(start.output.find("$.links[0].password_env: the variable SKROBOT_TEST_UNSET_LINK_PW is "
                              "not set"),
            std::string::npos)
      << start.output;
}

// audio-io in a process of its own: refused before init, it is unloaded, and libjack (under
// PortAudio) leaves its static allocations behind, which LeakSanitizer would blame on a test
// process that loads it in-process (tests/audio/audio_config_test.cpp).
TEST(SkrobotCli, CheckConfigReportsEveryProblemOfOneModule) {
  TempDir dir;
  auto cfg = dir.write("cfg.json", R"({"modules": [
      {"name": "audio-io", "config": {"sample_rate": 1000, "capture": "yes"}}]})");
  auto r = run({"--config", cfg.string(), "--check-config"});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("MODULE-CONFIG $.modules[0].config.sample_rate: must be >= 8000, got "
                          "1000"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("MODULE-CONFIG $.modules[0].config.capture: expected boolean, got "
                          "string"),
            std::string::npos)
      << r.output;
}

TEST(SkrobotCli, DescribeModulePrintsItsDeclaredKeys) {
  auto r = run({"--config", kDefaultConfig, "--describe-module", "example"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("period_ms"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("integer, default 1000, >= 1, <= 3600000"), std::string::npos)
      << r.output;
  auto missing = run({"--config", kDefaultConfig, "--describe-module", "no_such_module"});
  EXPECT_EQ(missing.exit_code, 1) << missing.output;
  EXPECT_NE(missing.output.find("MODULE-NOT-FOUND"), std::string::npos) << missing.output;
}

TEST(SkrobotCli, ListModulesShowsDescriptors) {
  auto r = run({"--config", kDefaultConfig, "--list-modules"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("example"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ABI 1."), std::string::npos) << r.output;
}

TEST(SkrobotCli, RunsModulesSurvivesBadOnesAndStopsInReverseOrderOnSignal) {
  for (int sig : {SIGTERM, SIGINT}) {
    TempDir dir;
    auto cfg = dir.write("cfg.json", R"({
      "app_name": "skrobot-cli-)" + std::to_string(getpid()) +
                                         R"(",
      "data_dir": "data",
      "module_paths": [")" SKROBOT_TEST_MODULE_DIR R"("],
      "modules": [
        {"name": "example", "config": {"greeting": "hi", "period_ms": 50}},
        {"name": "test_init_throws"},
        {"name": "not_there"},
        {"name": "test_plain_c"}
      ]})");
    const fs::path log = dir.path() / "hub.log";
    const pid_t pid = spawn({"--config", cfg.string()}, log);
    ASSERT_TRUE(waitFor(log, "HUB-READY")) << slurp(log);
    ASSERT_TRUE(waitFor(log, "EXAMPLE-TICK")) << slurp(log);
    kill(pid, sig);
    EXPECT_EQ(waitExit(pid), 0);
    const std::string out = slurp(log);
    EXPECT_NE(out.find("2 modules running, 2 failed"), std::string::npos) << out;
    EXPECT_NE(out.find("MODULE-INIT"), std::string::npos) << out;
    EXPECT_NE(out.find("MODULE-NOT-FOUND"), std::string::npos) << out;
    // Reverse order: test_plain_c stops before example.
    const auto plain = out.find("MODULE-STOPPED module test_plain_c");
    const auto example = out.find("MODULE-STOPPED module example");
    ASSERT_NE(plain, std::string::npos) << out;
    ASSERT_NE(example, std::string::npos) << out;
    EXPECT_LT(plain, example) << out;
    EXPECT_NE(out.find("HUB-STOP"), std::string::npos) << out;
  }
}

TEST(SkrobotCli, HubServesSatellitesOnItsUnixSocket) {
  TempDir dir;
  const std::string app = "skrobot-cli-sat-" + std::to_string(getpid());
  auto cfg = dir.write("cfg.json", R"({"app_name": ")" + app + R"(", "data_dir": "data",
      "accounts": {"dev_account": {"user": "guest", "password": "password"}}})");
  const fs::path log = dir.path() / "hub.log";
  const pid_t pid = spawn({"--config", cfg.string()}, log);
  ASSERT_TRUE(waitFor(log, "HUB-READY")) << slurp(log);
  EXPECT_NE(slurp(log).find("FLOW-DEV-ACCOUNT"), std::string::npos) << "the dev account is logged";
  {
    auto c = skr::test::TestClient::connectUnix("/tmp/" + app);
    ASSERT_TRUE(c) << c.error().message;
    auto ok = c->login("guest", "password");
    ASSERT_TRUE(ok) << ok.error().message;
    EXPECT_EQ(ok->app_name, app);
  }
  kill(pid, SIGTERM);
  EXPECT_EQ(waitExit(pid), 0);
  EXPECT_FALSE(fs::exists("/tmp/" + app)) << "the socket file is removed at exit";
}

TEST(SkrobotCli, TcpNeedsRealAccountsMadeWithTheUserCommand) {
  TempDir dir;
  const std::string app = "skrobot-cli-tcp-" + std::to_string(getpid());
  const std::string users = (dir.path() / "users.json").string();
  auto cfg = dir.write("cfg.json", R"({"app_name": ")" + app + R"(", "data_dir": "data",
      "server": {"tcp": true, "tcp_port": 0}, "accounts": {"users_file": "users.json"}})");
  auto refused = run({"--config", cfg.string()});
  EXPECT_EQ(refused.exit_code, 4) << refused.output;
  EXPECT_NE(refused.output.find("skrobot user add"), std::string::npos) << refused.output;

  // `skrobot user add` with the password on stdin, as a script would.
  const std::string cmd = std::string("echo 'r0b0t-pass' | ") + SKROBOT_BIN +
                          " user add operator --users " + users + " --password-stdin";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  auto listed = run({"user", "list", "--users", users});
  EXPECT_EQ(listed.exit_code, 0);
  EXPECT_NE(listed.output.find("operator"), std::string::npos) << listed.output;

  const fs::path log = dir.path() / "hub.log";
  const pid_t pid = spawn({"--config", cfg.string()}, log);
  ASSERT_TRUE(waitFor(log, "HUB-READY")) << slurp(log);
  EXPECT_NE(slurp(log).find("FLOW-LISTEN TCP"), std::string::npos) << slurp(log);
  kill(pid, SIGINT);
  EXPECT_EQ(waitExit(pid), 0);
}

}  // namespace
