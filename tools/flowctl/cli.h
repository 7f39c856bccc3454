// SPDX-License-Identifier: Apache-2.0
// flowctl internals: options, exit codes, argument helpers and output shared by the commands.
#pragma once

#include <skrobot/satellite.h>

#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace flowctl {

// Exit codes, stable for scripts (documented in `flowctl --help` and docs/cpp-satellites.md).
enum Exit : int {
  kOk = 0,
  kFailed = 1,           // the hub refused the command, or it failed otherwise
  kUsage = 2,            // bad command line
  kNoHub = 3,            // nobody listens at the address (or the hub went away)
  kLoginRefused = 4,     // wrong user name or password
  kNotFound = 5,         // no such channel, variable or database
  kTimeout = 6,          // a service call was not answered in time
  kDenied = 7,           // not allowed (someone else's channel or database)
  kAnsweredFailure = 8,  // call: the service answered that it failed ({"ok": false} or {"error"})
};

struct Cli {
  skr::sat::ConnectOptions connect;
  bool json = false;  // machine-readable output
  std::string command;
  std::vector<std::string> args;  // after the command
};

// Command-line arguments of one command: flags, options with values, positionals.
class Args {
 public:
  explicit Args(std::vector<std::string> args) : args_(std::move(args)) {}
  // "--name VALUE" or "--name=VALUE"; removes it. nullopt when absent; an error when the value
  // is missing (reported by error()).
  std::optional<std::string> option(std::string_view name);
  bool flag(std::string_view name);  // "--name"; removes it
  // What is left: positionals. An unknown "--option" left over is an error.
  [[nodiscard]] std::vector<std::string> rest();
  [[nodiscard]] const std::string& error() const { return error_; }

 private:
  std::vector<std::string> args_;
  std::string error_;
};

// Prints "flowctl: <message>" to stderr and returns `code`.
int fail(int code, const std::string& message);
// The exit code for a failed request (by its Errc).
int exitFor(const skr::Error& error);
// Connects the synchronous connection, or explains why not (and sets `code`).
std::optional<skr::sat::SyncClient> connectSync(const Cli& cli, int& code);
// serial: and udp: addresses carry the flow only (connectSync refuses them): commands that run on
// a flow skip their synchronous checks there.
[[nodiscard]] bool flowOnly(const Cli& cli);
// Runs one ADMIN command (administrators only; docs/security.md) and prints its answer: JSON
// with --json, else `print`. Exit 7 for an account that is not an administrator.
int runAdmin(const Cli& cli, const std::string& command, const skr::flow::Variant& args,
             const std::function<void(const skr::flow::Variant&)>& print);
// A member of a map as text: a string as it is, anything else as JSON, "" when absent.
std::string field(const skr::flow::Variant& map, const char* key);
// Parses a number argument; false (after printing a usage error) when it is not one.
bool parseNumber(const std::string& text, const char* what, double& out);
// Parses a JSON value argument; nullopt (after a usage error that says how to quote) when it is
// not JSON.
std::optional<skr::flow::Variant> jsonArg(const std::string& text, const char* what);

// Prints the usage of cli.command's row (commands.h) and returns kUsage.
int usageError(const Cli& cli);

// The handlers of the commands' rows (commands.cpp), by file. Each returns an exit code.
int cmdLs(const Cli& cli);       // cmd_ls.cpp
int cmdEcho(const Cli& cli);     // cmd_echo_poll.cpp
int cmdPoll(const Cli& cli);     // cmd_echo_poll.cpp
int cmdPub(const Cli& cli);      // cmd_pub.cpp
int cmdCall(const Cli& cli);     // cmd_call.cpp
int cmdDb(const Cli& cli);       // cmd_db.cpp
int cmdFlows(const Cli& cli);    // cmd_admin.cpp
int cmdKick(const Cli& cli);     // cmd_admin.cpp
int cmdChan(const Cli& cli);     // cmd_admin.cpp
int cmdUsers(const Cli& cli);    // cmd_admin.cpp
int cmdUser(const Cli& cli);     // cmd_admin.cpp
int cmdReload(const Cli& cli);   // cmd_admin.cpp
int cmdModule(const Cli& cli);   // cmd_admin.cpp
int cmdPs(const Cli& cli);       // cmd_sat.cpp
int cmdStart(const Cli& cli);    // cmd_sat.cpp
int cmdStop(const Cli& cli);     // cmd_sat.cpp
int cmdRestart(const Cli& cli);  // cmd_sat.cpp
int cmdLogs(const Cli& cli);     // cmd_sat.cpp
int cmdBlob(const Cli& cli);     // cmd_blob.cpp
int cmdSync(const Cli& cli);     // cmd_sync.cpp
int cmdLink(const Cli& cli);     // cmd_link.cpp
int cmdTop(const Cli& cli);      // cmd_top.cpp
int cmdHz(const Cli& cli);       // cmd_hz_bw.cpp
int cmdBw(const Cli& cli);       // cmd_hz_bw.cpp
int cmdInfo(const Cli& cli);     // cmd_info.cpp
int cmdGraph(const Cli& cli);    // cmd_graph.cpp
int cmdRecord(const Cli& cli);   // cmd_record.cpp
int cmdPlay(const Cli& cli);     // cmd_play.cpp
int cmdMcap(const Cli& cli);     // cmd_mcap.cpp

}  // namespace flowctl
