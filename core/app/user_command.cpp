// SPDX-License-Identifier: Apache-2.0
// `skrobot user ...`: add, remove, re-password and list the accounts of the users file.
#include "user_command.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/hub_config.h>
#include <skrobot/hub/install_layout.h>

#include <sodium.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace {

namespace fs = std::filesystem;
using skr::flow::UsersFile;

constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;

constexpr const char* kUsage =
    "usage: skrobot user add NAME    [--users FILE | --config FILE] [--password-stdin]\n"
    "       skrobot user del NAME    [--users FILE | --config FILE]\n"
    "       skrobot user passwd NAME [--users FILE | --config FILE] [--password-stdin]\n"
    "       skrobot user list        [--users FILE | --config FILE]\n"
    "       skrobot user show NAME   [--users FILE | --config FILE]\n"
    "       skrobot user role NAME admin|user             [--users FILE | --config FILE]\n"
    "       skrobot user rule NAME ACTION [PATTERN...]    [--users FILE | --config FILE]\n"
    "       skrobot user limit NAME WHAT N                [--users FILE | --config FILE]\n"
    "       skrobot user key NAME [--remove]              [--users FILE | --config FILE]\n"
    "\n"
    "  --users FILE      the users file (default: $SKROBOT_USERS, else the one the hub's\n"
    "                    config names: accounts.users_file, else <data_dir>/users.json)\n"
    "  --config FILE     the hub's config (default: as the hub's own, see skrobot --help)\n"
    "  --password-stdin  read the password as one line from stdin (also when stdin is not a\n"
    "                    terminal); otherwise it is asked twice, without echo\n"
    "\n"
    "NAME: 1..64 characters of [A-Za-z0-9_-]. Passwords are stored as argon2id hashes.\n"
    "ACTION: publish, subscribe, call, db_read or db_write; PATTERNs in the channel-name\n"
    "pattern syntax ('**', 'bob.*', '!bob.secret'); none: back to '**' (docs/security.md).\n"
    "WHAT: connections, channels, databases, pending_requests, blob_mib or blob_files;\n"
    "      N 0: the hub's limit.\n"
    "key: a new random 16-byte key for NAME's board (UDP sessions, server.udp), printed once in\n"
    "     hex for the board's sketch and replacing any older one; --remove: no UDP sessions.\n"
    "The hub reads roles and rules at login: restart it, or reconnect, to apply a change.\n"
    "Exit codes: 0 done, 1 the operation failed, 2 usage. See docs/accounts.md.\n";

struct Args {
  std::string verb;
  std::string name;
  std::vector<std::string> values;  // role: the role; rule: the action, then the patterns
  std::optional<fs::path> users;
  std::optional<fs::path> config;
  bool password_stdin = false;
  bool remove = false;  // key --remove
};

int usage(const std::string& problem) {
  std::fprintf(stderr, "skrobot user: %s\n%s", problem.c_str(), kUsage);
  return kExitUsage;
}

int failed(const std::string& problem) {
  std::fprintf(stderr, "skrobot user: %s\n", problem.c_str());
  return kExitFailed;
}

// The file the hub itself reads: $SKROBOT_USERS, else the users file of its config.
skr::Result<fs::path> defaultUsersFile(const std::optional<fs::path>& config) {
  if (const char* v = std::getenv("SKROBOT_USERS"); v != nullptr && *v != '\0' && !config) {
    return fs::path(v);
  }
  const fs::path file = config ? *config : skr::defaultConfigFile();
  auto cfg = skr::loadHubConfig(file, skr::ConfigPurpose::check);  // no link secrets needed
  if (!cfg) {
    return skr::makeError(cfg.error().code, "no users file: the config " + file.string() +
                                                " cannot be read (use --users FILE or --config "
                                                "FILE)\n" +
                                                cfg.error().message);
  }
  return cfg->server.users_file;
}

void wipe(std::string& secret) {
  if (!secret.empty()) sodium_memzero(secret.data(), secret.size());
}

// One line from fd 0, without its "\n" (or "\r\n"). Unbuffered, so that nothing after the line is
// consumed. nullopt on EOF before any byte, or on a read error.
std::optional<std::string> readLine() {
  std::string line;
  bool any = false;
  for (;;) {
    char c = 0;
    const ssize_t n = ::read(STDIN_FILENO, &c, 1);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return std::nullopt;
    if (n == 0) break;
    any = true;
    if (c == '\n') break;
    // Far beyond the limit: stop storing, validatePassword() refuses it anyway.
    if (line.size() <= skr::flow::kMaxPasswordBytes) line.push_back(c);
  }
  if (!any) return std::nullopt;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

// Terminal echo is turned off while a password is typed; these put it back if a signal ends us.
termios g_saved_termios{};
volatile sig_atomic_t g_echo_off = 0;

void restoreEchoAndDie(int sig) {
  if (g_echo_off != 0) ::tcsetattr(STDIN_FILENO, TCSAFLUSH, &g_saved_termios);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

std::optional<std::string> readHidden(const char* prompt) {
  std::fprintf(stderr, "%s", prompt);
  std::fflush(stderr);
  if (::tcgetattr(STDIN_FILENO, &g_saved_termios) != 0) return readLine();
  termios quiet = g_saved_termios;
  quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
  quiet.c_lflag |= ECHONL;
  const auto old_int = std::signal(SIGINT, restoreEchoAndDie);
  const auto old_term = std::signal(SIGTERM, restoreEchoAndDie);
  g_echo_off = 1;
  ::tcsetattr(STDIN_FILENO, TCSAFLUSH, &quiet);
  auto line = readLine();
  ::tcsetattr(STDIN_FILENO, TCSAFLUSH, &g_saved_termios);
  g_echo_off = 0;
  std::signal(SIGINT, old_int);
  std::signal(SIGTERM, old_term);
  return line;
}

// The new password of `name`, from the terminal (twice) or one line of stdin.
std::optional<std::string> askPassword(const Args& args, std::string& problem) {
  if (args.password_stdin || ::isatty(STDIN_FILENO) == 0) {
    auto line = readLine();
    if (!line) problem = "no password on stdin";
    return line;
  }
  const std::string prompt = "Password for " + args.name + ": ";
  auto first = readHidden(prompt.c_str());
  if (!first) {
    problem = "no password entered";
    return std::nullopt;
  }
  auto again = readHidden("Again: ");
  if (!again || *again != *first) {
    wipe(*first);
    if (again) wipe(*again);
    problem = "the two passwords differ; nothing changed";
    return std::nullopt;
  }
  wipe(*again);
  return first;
}

// Parses everything after "user". Returns an error text for usage problems, empty when fine.
std::string parse(int argc, char** argv, Args& out) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "--users") {
      if (i + 1 >= argc) return "--users needs a FILE";
      out.users = fs::path(argv[++i]);
    } else if (a.rfind("--users=", 0) == 0) {
      out.users = fs::path(std::string(a.substr(8)));
    } else if (a == "--config") {
      if (i + 1 >= argc) return "--config needs a FILE";
      out.config = fs::path(argv[++i]);
    } else if (a == "--password-stdin") {
      out.password_stdin = true;
    } else if (a == "--remove" && out.verb == "key") {
      out.remove = true;
    } else if (a.size() > 1 && a[0] == '-' && !(out.verb == "rule" && out.values.size() >= 1)) {
      return "unknown option " + std::string(a);
    } else if (out.verb.empty()) {
      out.verb = a;
    } else if (out.name.empty() && out.verb != "list") {
      out.name = a;
    } else if (out.verb == "role" || out.verb == "rule" || out.verb == "limit") {
      out.values.emplace_back(a);
    } else {
      return "unexpected argument " + std::string(a);
    }
  }
  if (out.verb.empty()) return "missing command";
  const std::vector<std::string_view> verbs = {"add",  "del",  "passwd", "list", "show",
                                               "role", "rule", "limit",  "key"};
  if (std::find(verbs.begin(), verbs.end(), out.verb) == verbs.end()) {
    return "unknown command " + out.verb;
  }
  if (out.verb == "role" &&
      (out.values.size() != 1 || (out.values[0] != "admin" && out.values[0] != "user"))) {
    return "role needs NAME and admin or user";
  }
  if (out.verb == "rule" && out.values.empty()) return "rule needs NAME and an ACTION";
  if (out.verb == "limit" && out.values.size() != 2) return "limit needs NAME, WHAT and N";
  if (out.verb != "list" && out.name.empty()) return out.verb + " needs a user NAME";
  if (out.users && out.users->empty()) return "--users needs a FILE";
  if (out.users && out.config) return "--users and --config exclude each other";
  return {};
}

int save(const UsersFile& file) {
  if (auto saved = file.save(); !saved) return failed("cannot save: " + saved.error().message);
  return kExitOk;
}

int run(const Args& args, const fs::path& path) {
  auto loaded = UsersFile::load(path);
  if (!loaded) return failed("cannot read the users file: " + loaded.error().message);
  UsersFile& file = loaded.value();

  if (args.verb == "list") {
    for (const auto& name : file.names()) std::printf("%s\n", name.c_str());
    if (file.empty()) std::fprintf(stderr, "no users in %s\n", path.c_str());
    return kExitOk;
  }
  if (args.verb == "show" || args.verb == "role" || args.verb == "rule" || args.verb == "limit") {
    if (!file.contains(args.name)) return failed("no user " + args.name + " in " + path.string());
    skr::flow::AccessRules access = *file.accessOf(args.name);
    if (args.verb == "role") {
      access.setRole(args.values[0] == "admin" ? skr::flow::Role::admin : skr::flow::Role::user);
    } else if (args.verb == "limit") {
      skr::flow::UserLimits limits = access.limits();
      uint32_t* field = limits.field(args.values[0]);
      if (field == nullptr) {
        return failed("unknown limit " + args.values[0] + " (" + skr::flow::UserLimits::kNames +
                      ")");
      }
      char* end = nullptr;
      const unsigned long n = std::strtoul(args.values[1].c_str(), &end, 10);
      if (args.values[1].empty() || *end != '\0' || n > 1'000'000) {
        return failed("N must be an integer from 0 (the hub's limit) to 1000000");
      }
      *field = static_cast<uint32_t>(n);
      access.setLimits(limits);
    } else if (args.verb == "rule") {
      std::optional<skr::flow::Action> action;
      for (auto a :
           {skr::flow::Action::publish, skr::flow::Action::subscribe, skr::flow::Action::call,
            skr::flow::Action::db_read, skr::flow::Action::db_write}) {
        if (skr::flow::actionName(a) == args.values[0]) action = a;
      }
      if (!action) {
        return failed("unknown ACTION " + args.values[0] +
                      " (publish, subscribe, call, db_read, db_write)");
      }
      std::vector<std::string> patterns(args.values.begin() + 1, args.values.end());
      if (patterns.empty()) patterns.emplace_back("**");
      if (auto set = access.setRule(*action, patterns); !set) return failed(set.error().message);
    }
    if (args.verb != "show") {
      if (auto set = file.setAccess(args.name, access); !set) return failed(set.error().message);
      if (const int rc = save(file); rc != kExitOk) return rc;
    }
    std::printf("%s: role %s\n", args.name.c_str(), access.admin() ? "admin" : "user");
    for (auto a :
         {skr::flow::Action::publish, skr::flow::Action::subscribe, skr::flow::Action::call,
          skr::flow::Action::db_read, skr::flow::Action::db_write}) {
      std::string line;
      for (const auto& p : access.patterns(a)) line += (line.empty() ? "" : " ") + p;
      std::printf("  %-9s %s\n", std::string(skr::flow::actionName(a)).c_str(), line.c_str());
    }
    const skr::flow::UserLimits& l = access.limits();
    const auto shown = [](uint32_t n) { return n == 0 ? std::string("hub's") : std::to_string(n); };
    std::printf(
        "  limits    connections %s, channels %s, databases %s, pending_requests %s, blob_mib %s, "
        "blob_files %s\n",
        shown(l.connections).c_str(), shown(l.channels).c_str(), shown(l.databases).c_str(),
        shown(l.pending_requests).c_str(), shown(l.blob_mib).c_str(), shown(l.blob_files).c_str());
    return kExitOk;
  }
  if (args.verb == "key") {
    if (!file.contains(args.name)) return failed("no user " + args.name + " in " + path.string());
    std::optional<skr::flow::UdpKey> key;
    if (!args.remove) {
      if (auto ready = skr::flow::sodiumReady(); !ready) return failed(ready.error().message);
      key.emplace();
      randombytes_buf(key->data(), key->size());
    }
    if (auto set = file.setUdpKey(args.name, key); !set) return failed(set.error().message);
    if (const int rc = save(file); rc != kExitOk) return rc;
    if (!key) {
      std::printf("removed the UDP key of %s\n", args.name.c_str());
      return kExitOk;
    }
    char hex[2 * 16 + 1];
    sodium_bin2hex(hex, sizeof hex, key->data(), key->size());
    sodium_memzero(key->data(), key->size());
    std::printf("%s\n", hex);
    std::fprintf(stderr,
                 "the UDP key of %s (shown once: put it in the board's sketch; the hub reads it "
                 "at its next start or reload)\n",
                 args.name.c_str());
    sodium_memzero(hex, sizeof hex);
    return kExitOk;
  }
  if (args.verb == "del") {
    if (auto removed = file.remove(args.name); !removed) {
      return failed("no user " + args.name + " in " + path.string());
    }
    if (const int rc = save(file); rc != kExitOk) return rc;
    std::printf("removed user %s\n", args.name.c_str());
    return kExitOk;
  }

  // add, passwd: check what can be checked before asking for a password.
  const bool adding = args.verb == "add";
  if (adding && file.contains(args.name)) {
    return failed("user " + args.name + " already exists in " + path.string() +
                  " (skrobot user passwd " + args.name + " changes the password)");
  }
  if (!adding && !file.contains(args.name)) {
    return failed("no user " + args.name + " in " + path.string());
  }
  std::string problem;
  auto password = askPassword(args, problem);
  if (!password) return failed(problem);
  auto changed = adding ? file.add(args.name, *password) : file.setPassword(args.name, *password);
  wipe(*password);
  if (!changed) return failed(changed.error().message);
  if (const int rc = save(file); rc != kExitOk) return rc;
  if (adding) {
    std::printf("added user %s\n", args.name.c_str());
  } else {
    std::printf("changed the password of %s\n", args.name.c_str());
  }
  return kExitOk;
}

}  // namespace

int runUserCommand(int argc, char** argv) {
  Args args;
  if (argc >= 2 && (std::string_view(argv[1]) == "--help" || std::string_view(argv[1]) == "-h" ||
                    std::string_view(argv[1]) == "help")) {
    std::printf("%s", kUsage);
    return kExitOk;
  }
  if (const std::string problem = parse(argc, argv, args); !problem.empty()) {
    return usage(problem);
  }
  if (args.verb != "list") {
    if (auto valid = skr::flow::validateUserName(args.name); !valid) {
      return usage(valid.error().message);
    }
  }
  const auto path = args.users ? skr::Result<fs::path>(*args.users) : defaultUsersFile(args.config);
  if (!path) return failed(path.error().message);
  std::fprintf(stderr, "users file: %s\n", path->c_str());
  const int rc = run(args, *path);
  std::fflush(stdout);
  return rc;
}
