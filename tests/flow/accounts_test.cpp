// SPDX-License-Identifier: Apache-2.0
// Users file, Authenticator and `skrobot user`. argon2id costs ~0.1 s per hash: each test notes
// how many it spends (about 25 in all).
#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/hub_config.h>
#include <skrobot/runtime/loop.h>
#include "temp_dir.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "user_command.h"

namespace skr::flow {
namespace {

namespace fs = std::filesystem;
using skr::test::TempDir;

std::string readFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeFile(const fs::path& p, const std::string& text) {
  {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out << text;
  }
  fs::permissions(p, fs::perms::owner_read | fs::perms::owner_write);  // no ACCOUNTS-PERMS noise
}

// --- UsersFile ------------------------------------------------------------------------------

TEST(UsersFile, AddVerifyPasswdRemove) {  // 7 argon2id
  UsersFile users;
  ASSERT_TRUE(users.add("alice", "s3cret"));
  EXPECT_TRUE(users.contains("alice"));
  EXPECT_TRUE(users.verify("alice", "s3cret"));
  EXPECT_FALSE(users.verify("alice", "wrong"));
  EXPECT_FALSE(users.verify("bob", "s3cret"));  // unknown: a dummy hash, still false

  auto again = users.add("alice", "other");
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().code, Errc::already_exists);

  ASSERT_TRUE(users.setPassword("alice", "n3w"));
  EXPECT_TRUE(users.verify("alice", "n3w"));
  EXPECT_FALSE(users.verify("alice", "s3cret"));
  EXPECT_EQ(users.setPassword("bob", "x").error().code, Errc::not_found);

  ASSERT_TRUE(users.remove("alice"));
  EXPECT_FALSE(users.contains("alice"));
  EXPECT_EQ(users.remove("alice").error().code, Errc::not_found);
}

TEST(UsersFile, SavedFileHasMode0600AndNoPassword) {  // 2 argon2id
  TempDir dir;
  const fs::path file = dir.path() / "sub" / "users.json";  // parent created by save()
  const std::string password = "Pa55-word-in-clear";
  UsersFile users(file);
  ASSERT_TRUE(users.add("carol", password));
  ASSERT_TRUE(users.save());

  struct stat st {};
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  const std::string text = readFile(file);
  EXPECT_EQ(text.find(password), std::string::npos);
  EXPECT_NE(text.find("$argon2id$"), std::string::npos);
  EXPECT_NE(text.find("\"format\" : 1"), std::string::npos) << text;
  for (const auto& entry : fs::directory_iterator(file.parent_path())) {
    EXPECT_EQ(entry.path().filename(), "users.json") << "left behind: " << entry.path();
  }

  auto loaded = UsersFile::load(file);
  ASSERT_TRUE(loaded) << loaded.error().describe();
  EXPECT_EQ(loaded->names(), std::vector<std::string>{"carol"});
  EXPECT_EQ(loaded->hashOf("carol"), users.hashOf("carol"));
  EXPECT_EQ(loaded->createdOf("carol")->size(), 20u);  // 2026-01-02T03:04:05Z
  EXPECT_TRUE(loaded->verify("carol", password));
}

TEST(UsersFile, MissingFileIsEmptyAndNamesSorted) {  // 0 argon2id
  TempDir dir;
  auto loaded = UsersFile::load(dir.path() / "none.json");
  ASSERT_TRUE(loaded) << loaded.error().describe();
  EXPECT_TRUE(loaded->empty());
  EXPECT_EQ(loaded->path(), dir.path() / "none.json");

  const std::string hash(dummyPasswordHash());
  writeFile(dir.path() / "u.json", R"({"format": 1, "users": {"zed": {"hash": ")" + hash +
                                       R"(", "created": "x"}, "amy": {"hash": ")" + hash +
                                       R"(", "created": "y"}}})");
  auto two = UsersFile::load(dir.path() / "u.json");
  ASSERT_TRUE(two) << two.error().describe();
  EXPECT_EQ(two->names(), (std::vector<std::string>{"amy", "zed"}));
}

TEST(UsersFile, CorruptFileIsReportedWithPathAndReason) {  // 0 argon2id
  TempDir dir;
  const fs::path file = dir.path() / "users.json";
  const std::string hash(dummyPasswordHash());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{not json", "not valid JSON"},
      {"[]", "top level"},
      {R"({"format": 2, "users": {}})", "\"format\""},
      {R"({"format": 1, "users": []})", "\"users\""},
      {R"({"format": 1, "users": {"a": {"hash": "plain"}}})", "argon2id"},
      {R"({"format": 1, "users": {"a.b": {"hash": ")" + hash + R"("}}})", "may contain only"},
      // Nesting past the JSON reader's stack limit (it throws; found by users_file_fuzz).
      {R"({"format":)" + std::string(1100, '[') + std::string(1100, ']') + "}", "not valid JSON"},
  };
  for (const auto& [text, reason] : cases) {
    writeFile(file, text);
    auto loaded = UsersFile::load(file);
    ASSERT_FALSE(loaded) << text;
    EXPECT_EQ(loaded.error().code, Errc::parse_error) << text;
    EXPECT_NE(loaded.error().message.find(file.string()), std::string::npos)
        << loaded.error().message;
    EXPECT_NE(loaded.error().message.find(reason), std::string::npos) << loaded.error().message;
  }
}

TEST(UsersFile, InvalidNamesAndPasswordsAreRefused) {  // 0 argon2id
  for (const std::string& bad :
       std::vector<std::string>{"", "a.b", "a b", "é", "a/b", std::string(65, 'x')}) {
    auto r = validateUserName(bad);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().code, Errc::invalid_argument);
  }
  EXPECT_TRUE(validateUserName("Ok_name-9"));
  EXPECT_TRUE(validateUserName(std::string(64, 'x')));
  EXPECT_EQ(validatePassword("").error().code, Errc::invalid_argument);
  EXPECT_EQ(validatePassword(std::string(1025, 'p')).error().code, Errc::invalid_argument);
  EXPECT_TRUE(validatePassword(std::string(1024, 'p')));

  UsersFile users;
  EXPECT_EQ(users.add("a.b", "pw").error().code, Errc::invalid_argument);
  EXPECT_EQ(users.add("ok", "").error().code, Errc::invalid_argument);
  EXPECT_TRUE(users.empty());
}

// --- Authenticator --------------------------------------------------------------------------

struct Answer {
  LoginResult result;
  std::thread::id thread;
};

// Starts a login, checks that `done` is not called inside verify(), runs the loop until answered.
Answer login(Authenticator& auth, Loop& loop, const std::string& user, const std::string& password,
             Transport transport) {
  std::optional<Answer> answer;
  auth.verify(user, password, transport, [&answer](LoginResult r) {
    answer = Answer{std::move(r), std::this_thread::get_id()};
  });
  EXPECT_FALSE(answer.has_value()) << "done ran inside verify()";
  EXPECT_TRUE(loop.runUntil([&] { return answer.has_value(); }, 30 * kNsPerSec));
  return answer.value_or(Answer{});
}

TEST(Authenticator, DevAccountOnlyOnUnixSocket) {  // 0 argon2id
  Loop loop;
  Authenticator auth(UsersFile(), DevAccount{"guest", "password"}, loop);
  EXPECT_FALSE(auth.hasRealAccounts());
  EXPECT_TRUE(auth.hasDevAccount());

  const auto unix_ok = login(auth, loop, "guest", "password", Transport::unix_socket);
  EXPECT_TRUE(unix_ok.result.ok) << unix_ok.result.reason;
  const auto tcp = login(auth, loop, "guest", "password", Transport::tcp);
  EXPECT_FALSE(tcp.result.ok);
  EXPECT_NE(tcp.result.reason.find("Unix socket only"), std::string::npos) << tcp.result.reason;
  EXPECT_FALSE(login(auth, loop, "guest", "password", Transport::in_process).result.ok);
  EXPECT_FALSE(login(auth, loop, "guest", "passwort", Transport::unix_socket).result.ok);
  EXPECT_FALSE(login(auth, loop, "bad.name", "x", Transport::unix_socket).result.ok);
  EXPECT_EQ(auth.argon2Verifications(), 0u);
}

// server.web.dev_account: the development account also on WebSocket, but only from this machine
// (the connection's kind says so: websocket_loopback for a peer on 127.0.0.0/8 or ::1).
TEST(Authenticator, DevAccountOnWebSocketOnlyFromLoopback) {  // 0 argon2id
  Loop loop;
  Authenticator web(UsersFile(), DevAccount{"guest", "password", true}, loop);
  EXPECT_TRUE(login(web, loop, "guest", "password", Transport::websocket_loopback).result.ok);
  const auto remote = login(web, loop, "guest", "password", Transport::websocket);
  EXPECT_FALSE(remote.result.ok);
  EXPECT_NE(remote.result.reason.find("loopback only"), std::string::npos) << remote.result.reason;
  EXPECT_FALSE(login(web, loop, "guest", "password", Transport::tcp).result.ok);
  EXPECT_TRUE(login(web, loop, "guest", "password", Transport::unix_socket).result.ok);
  // Without the config's consent, not on WebSocket at all.
  Authenticator plain(UsersFile(), DevAccount{"guest", "password"}, loop);
  EXPECT_FALSE(login(plain, loop, "guest", "password", Transport::websocket_loopback).result.ok);
  EXPECT_EQ(web.argon2Verifications() + plain.argon2Verifications(), 0u);
}

TEST(Authenticator, VerifiesOnWorkerAnswersOnLoopAndCaches) {  // 4 argon2id
  UsersFile users;
  ASSERT_TRUE(users.add("alice", "pw-alice"));
  Loop loop;
  Authenticator auth(std::move(users), std::nullopt, loop);
  EXPECT_TRUE(auth.hasRealAccounts());
  const auto loop_thread = std::this_thread::get_id();

  const auto first = login(auth, loop, "alice", "pw-alice", Transport::tcp);
  EXPECT_TRUE(first.result.ok) << first.result.reason;
  EXPECT_EQ(first.thread, loop_thread);
  EXPECT_EQ(auth.argon2Verifications(), 1u);
  EXPECT_NE(auth.lastArgon2Thread(), loop_thread);
  EXPECT_NE(auth.lastArgon2Thread(), std::thread::id());

  const auto second = login(auth, loop, "alice", "pw-alice", Transport::unix_socket);
  EXPECT_TRUE(second.result.ok);
  EXPECT_EQ(second.result.reason, "cached verification");
  EXPECT_EQ(second.thread, loop_thread);
  EXPECT_EQ(auth.argon2Verifications(), 1u);

  const auto wrong = login(auth, loop, "alice", "pw-bob", Transport::tcp);
  EXPECT_FALSE(wrong.result.ok);
  EXPECT_EQ(wrong.result.reason, "wrong password");
  EXPECT_EQ(auth.argon2Verifications(), 2u);

  const auto unknown = login(auth, loop, "bob", "pw-alice", Transport::tcp);
  EXPECT_FALSE(unknown.result.ok);
  EXPECT_EQ(unknown.result.reason, "unknown user");
  EXPECT_EQ(unknown.thread, loop_thread);
  EXPECT_EQ(auth.argon2Verifications(), 3u);  // the dummy hash, not an early answer
}

TEST(Authenticator, ManySimultaneousLoginsCostOneArgon2) {  // 2 argon2id
  UsersFile users;
  ASSERT_TRUE(users.add("robot", "same"));
  Loop loop;
  Authenticator auth(std::move(users), std::nullopt, loop);
  int ok = 0;
  int answered = 0;
  for (int i = 0; i < 20; ++i) {
    auth.verify("robot", "same", Transport::unix_socket, [&](LoginResult r) {
      ++answered;
      ok += r.ok ? 1 : 0;
    });
  }
  ASSERT_TRUE(loop.runUntil([&] { return answered == 20; }, 30 * kNsPerSec));
  EXPECT_EQ(ok, 20);
  EXPECT_EQ(auth.argon2Verifications(), 1u);
  EXPECT_EQ(auth.cacheSize(), 1u);
}

TEST(Authenticator, ReloadDropsCacheOnPasswordChangeAndRemoval) {  // 6 argon2id
  TempDir dir;
  const fs::path file = dir.path() / "users.json";
  {
    UsersFile users(file);
    ASSERT_TRUE(users.add("alice", "one"));
    ASSERT_TRUE(users.save());
  }
  Loop loop;
  auto created = Authenticator::create(file, DevAccount{"guest", "password"}, loop);
  ASSERT_TRUE(created) << created.error().describe();
  Authenticator& auth = **created;

  EXPECT_TRUE(login(auth, loop, "alice", "one", Transport::tcp).result.ok);
  EXPECT_TRUE(login(auth, loop, "alice", "one", Transport::tcp).result.ok);
  EXPECT_EQ(auth.argon2Verifications(), 1u);

  {  // what `skrobot user passwd alice` does, from another process
    auto users = UsersFile::load(file);
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->setPassword("alice", "two"));
    ASSERT_TRUE(users->save());
  }
  ASSERT_TRUE(auth.reload());
  EXPECT_EQ(auth.cacheSize(), 0u);
  const auto old = login(auth, loop, "alice", "one", Transport::tcp);
  EXPECT_FALSE(old.result.ok);
  EXPECT_EQ(old.result.reason, "wrong password");
  EXPECT_EQ(auth.argon2Verifications(), 2u);
  EXPECT_TRUE(login(auth, loop, "alice", "two", Transport::tcp).result.ok);
  EXPECT_EQ(auth.argon2Verifications(), 3u);

  {
    auto users = UsersFile::load(file);
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->remove("alice"));
    ASSERT_TRUE(users->save());
  }
  ASSERT_TRUE(auth.reload());
  EXPECT_FALSE(auth.hasRealAccounts());
  EXPECT_EQ(auth.cacheSize(), 0u);
  EXPECT_FALSE(login(auth, loop, "alice", "two", Transport::tcp).result.ok);

  writeFile(file, "{broken");
  auto bad = auth.reload();
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, Errc::parse_error);
  EXPECT_TRUE(login(auth, loop, "guest", "password", Transport::unix_socket).result.ok);
}

TEST(Authenticator, CreateRefusesCorruptFileAndBadDevAccount) {  // 0 argon2id
  TempDir dir;
  Loop loop;
  writeFile(dir.path() / "users.json", "nope");
  EXPECT_FALSE(Authenticator::create(dir.path() / "users.json", std::nullopt, loop));
  EXPECT_FALSE(Authenticator::create(dir.path() / "none.json", DevAccount{"a.b", "pw"}, loop));
  EXPECT_FALSE(Authenticator::create(dir.path() / "none.json", DevAccount{"guest", ""}, loop));
  auto ok = Authenticator::create(dir.path() / "none.json", std::nullopt, loop);
  ASSERT_TRUE(ok);
  EXPECT_FALSE((*ok)->hasRealAccounts());
}

TEST(Authenticator, DestructionDropsPendingCallbacks) {  // at most 1 argon2id
  Loop loop;
  int called = 0;
  {
    Authenticator auth(UsersFile(), std::nullopt, loop);
    for (int i = 0; i < 3; ++i) {
      auth.verify("nobody", "pw", Transport::tcp, [&called](LoginResult) { ++called; });
    }
  }
  std::atomic<bool> pumped{false};
  loop.post([&pumped] { pumped = true; });
  ASSERT_TRUE(loop.runUntil([&] { return pumped.load(); }, 10 * kNsPerSec));
  EXPECT_EQ(called, 0);
}

// --- skrobot user ---------------------------------------------------------------------------

struct CliRun {
  int rc = -1;
  std::string out;
  std::string err;
};

// Runs runUserCommand({"user", args...}) with `input` as stdin (a pipe), capturing stdout/stderr.
CliRun runCli(std::vector<std::string> args, const std::string& input = "") {
  args.insert(args.begin(), "user");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  int fds[2];
  EXPECT_EQ(::pipe(fds), 0);
  EXPECT_EQ(::write(fds[1], input.data(), input.size()), static_cast<ssize_t>(input.size()));
  ::close(fds[1]);
  const int saved_stdin = ::dup(STDIN_FILENO);
  ::dup2(fds[0], STDIN_FILENO);
  ::close(fds[0]);

  CliRun run;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  run.rc = runUserCommand(static_cast<int>(args.size()), argv.data());
  run.err = testing::internal::GetCapturedStderr();
  run.out = testing::internal::GetCapturedStdout();
  ::dup2(saved_stdin, STDIN_FILENO);
  ::close(saved_stdin);
  return run;
}

TEST(UserCommand, KeyMakesABoardsUdpKeyPrintsItOnceAndRemovesIt) {  // 1 argon2id
  TempDir dir;
  const std::string file = (dir.path() / "users.json").string();
  {
    auto users = UsersFile::load(file);
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->add("board", "pw"));
    ASSERT_TRUE(users->save());
  }
  auto key = runCli({"key", "board", "--users", file});
  ASSERT_EQ(key.rc, 0) << key.err;
  ASSERT_EQ(key.out.size(), 33u) << key.out;  // 32 hex digits and a newline
  UdpKey printed{};
  ASSERT_EQ(
      sodium_hex2bin(printed.data(), printed.size(), key.out.data(), 32, nullptr, nullptr, nullptr),
      0);
  EXPECT_EQ(readFile(file).find(key.out.substr(0, 32)), std::string::npos);  // base64 there
  auto users = UsersFile::load(file);
  ASSERT_TRUE(users);
  ASSERT_TRUE(users->udpKeyOf("board"));
  EXPECT_EQ(*users->udpKeyOf("board"), printed);
  EXPECT_TRUE(users->verify("board", "pw"));  // the password stays

  auto again = runCli({"key", "board", "--users", file});
  ASSERT_EQ(again.rc, 0) << again.err;
  EXPECT_NE(again.out, key.out);
  auto removed = runCli({"key", "board", "--remove", "--users", file});
  EXPECT_EQ(removed.rc, 0) << removed.err;
  users = UsersFile::load(file);
  ASSERT_TRUE(users);
  EXPECT_FALSE(users->udpKeyOf("board"));
  EXPECT_EQ(runCli({"key", "nobody", "--users", file}).rc, 1);
  EXPECT_EQ(runCli({"list", "--remove", "--users", file}).rc, 2);
}

TEST(UsersFile, AUdpKeyThatIsNotSixteenBytesIsRefused) {
  TempDir dir;
  const auto file = dir.path() / "users.json";
  const std::string hash(dummyPasswordHash());
  writeFile(file,
            R"({"format": 1, "users": {"b": {"hash": ")" + hash + R"(", "udp_key": "AAAA"}}})");
  auto users = UsersFile::load(file);
  ASSERT_FALSE(users);
  EXPECT_NE(users.error().message.find("users.b.udp_key"), std::string::npos)
      << users.error().message;
}

TEST(UserCommand, AddListPasswdDel) {  // 3 argon2id
  TempDir dir;
  const std::string file = (dir.path() / "users.json").string();
  const std::vector<std::string> opt = {"--users", file};
  const auto with = [&opt](std::vector<std::string> a) {
    a.insert(a.end(), opt.begin(), opt.end());
    return a;
  };

  auto add = runCli(with({"add", "alice", "--password-stdin"}), "first-pw\n");
  EXPECT_EQ(add.rc, 0) << add.err;
  EXPECT_NE(add.err.find("users file: " + file), std::string::npos) << add.err;
  struct stat st {};
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(readFile(file).find("first-pw"), std::string::npos);

  auto dup = runCli(with({"add", "alice", "--password-stdin"}), "x\n");
  EXPECT_EQ(dup.rc, 1);
  EXPECT_NE(dup.err.find("already exists"), std::string::npos) << dup.err;

  auto list = runCli(with({"list"}));
  EXPECT_EQ(list.rc, 0) << list.err;
  EXPECT_EQ(list.out, "alice\n");

  auto passwd = runCli(with({"passwd", "alice", "--password-stdin"}), "second-pw\r\n");
  EXPECT_EQ(passwd.rc, 0) << passwd.err;
  auto loaded = UsersFile::load(file);
  ASSERT_TRUE(loaded);
  EXPECT_TRUE(loaded->verify("alice", "second-pw"));

  EXPECT_EQ(runCli(with({"passwd", "bob", "--password-stdin"}), "x\n").rc, 1);
  auto del_bob = runCli(with({"del", "bob"}));
  EXPECT_EQ(del_bob.rc, 1);
  EXPECT_NE(del_bob.err.find("no user bob"), std::string::npos) << del_bob.err;

  EXPECT_EQ(runCli(with({"del", "alice"})).rc, 0);
  auto empty = runCli(with({"list"}));
  EXPECT_EQ(empty.rc, 0);
  EXPECT_EQ(empty.out, "");
}

TEST(UserCommand, UsageAndFailures) {  // 0 argon2id
  TempDir dir;
  const std::string file = (dir.path() / "users.json").string();
  EXPECT_EQ(runCli({}).rc, 2);
  EXPECT_EQ(runCli({"frob"}).rc, 2);
  EXPECT_EQ(runCli({"add", "--users", file}).rc, 2);
  EXPECT_EQ(runCli({"add", "a.b", "--users", file}).rc, 2);
  EXPECT_EQ(runCli({"list", "extra", "--users", file}).rc, 2);
  EXPECT_EQ(runCli({"list", "--bogus"}).rc, 2);
  EXPECT_EQ(runCli({"list", "--users"}).rc, 2);
  EXPECT_EQ(runCli({"--help"}).rc, 0);

  // No password, or an empty one: nothing written.
  EXPECT_EQ(runCli({"add", "alice", "--users", file, "--password-stdin"}, "").rc, 1);
  auto empty = runCli({"add", "alice", "--users", file, "--password-stdin"}, "\n");
  EXPECT_EQ(empty.rc, 1);
  EXPECT_NE(empty.err.find("password is empty"), std::string::npos) << empty.err;
  EXPECT_FALSE(fs::exists(file));

  writeFile(file, "{corrupt");
  auto corrupt = runCli({"list", "--users", file});
  EXPECT_EQ(corrupt.rc, 1);
  EXPECT_NE(corrupt.err.find("corrupt"), std::string::npos) << corrupt.err;
}

TEST(UserCommand, DefaultFileFromEnvironment) {  // 0 argon2id
  TempDir dir;
  const std::string from_env = (dir.path() / "env-users.json").string();
  ::setenv("SKROBOT_USERS", from_env.c_str(), 1);
  auto env = runCli({"list"});
  EXPECT_EQ(env.rc, 0);
  EXPECT_NE(env.err.find("users file: " + from_env), std::string::npos) << env.err;

  ::unsetenv("SKROBOT_USERS");
  // Without --users: the file the hub reads, from its config (here: <data_dir>/users.json with
  // the default data_dir under $XDG_DATA_HOME, and an explicit accounts.users_file).
  ::setenv("XDG_DATA_HOME", dir.path().c_str(), 1);
  const std::string config = (dir.path() / "hub.json").string();
  writeFile(config, R"({"app_name": "UsersT", "modules": []})");
  auto xdg = runCli({"list", "--config", config});
  EXPECT_EQ(xdg.rc, 0) << xdg.err;
  const std::string expected = (dir.path() / "skrobot/UsersT/users.json").string();
  EXPECT_NE(xdg.err.find("users file: " + expected), std::string::npos) << xdg.err;
  auto hub = loadHubConfig(config);
  ASSERT_TRUE(hub);
  EXPECT_EQ(hub->server.users_file.string(), expected);

  const std::string named = (dir.path() / "named.json").string();
  writeFile(config, R"({"app_name": "UsersT", "accounts": {"users_file": ")" + named + R"("}})");
  auto explicit_file = runCli({"list", "--config", config});
  EXPECT_EQ(explicit_file.rc, 0) << explicit_file.err;
  EXPECT_NE(explicit_file.err.find("users file: " + named), std::string::npos) << explicit_file.err;

  auto missing = runCli({"list", "--config", (dir.path() / "nope.json").string()});
  EXPECT_EQ(missing.rc, 1);
  EXPECT_NE(missing.err.find("nope.json"), std::string::npos) << missing.err;
  ::unsetenv("XDG_DATA_HOME");
}

}  // namespace
}  // namespace skr::flow

namespace skr::flow {
namespace {

TEST(UserCommand, RolesAndRules) {  // 1 argon2id
  TempDir dir;
  const std::string file = (dir.path() / "users.json").string();
  ASSERT_EQ(runCli({"add", "alice", "--users", file, "--password-stdin"}, "pw\n").rc, 0);
  EXPECT_EQ(runCli({"role", "alice", "admin", "--users", file}).rc, 0);
  EXPECT_EQ(runCli({"rule", "alice", "subscribe", "**", "!bob.secret", "--users", file}).rc, 0);
  EXPECT_EQ(runCli({"rule", "alice", "call", "speech.*", "--users", file}).rc, 0);
  EXPECT_EQ(runCli({"rule", "alice", "call", "--users", file}).rc, 0);  // back to "**"
  EXPECT_EQ(runCli({"role", "alice", "root", "--users", file}).rc, 2);
  EXPECT_EQ(runCli({"rule", "alice", "sing", "x", "--users", file}).rc, 1);
  EXPECT_EQ(runCli({"rule", "alice", "call", "a b", "--users", file}).rc, 1);
  EXPECT_EQ(runCli({"rule", "bob", "call", "x", "--users", file}).rc, 1);
  auto shown = runCli({"show", "alice", "--users", file});
  EXPECT_EQ(shown.rc, 0);
  EXPECT_NE(shown.out.find("role admin"), std::string::npos) << shown.out;
  auto users = UsersFile::load(file);
  ASSERT_TRUE(users);
  const auto access = users->accessOf("alice");
  EXPECT_TRUE(access->admin());
  EXPECT_EQ(access->patterns(Action::subscribe), (std::vector<std::string>{"**", "!bob.secret"}));
  EXPECT_EQ(access->patterns(Action::call), std::vector<std::string>{"**"});
}

}  // namespace
}  // namespace skr::flow
