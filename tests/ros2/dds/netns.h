// SPDX-License-Identifier: Apache-2.0
// A DDS test program in a network namespace of its own, as dds_core_test does it: main() calls
// enterOwnNetworkNamespace first. Outside the namespace it re-runs the program under
// `unshare --net` (with --map-root-user when not root) and does not return unless that fails;
// inside, it brings lo up and checks that lo is the only interface, so that nothing a test sends
// can leave the machine and tests run in parallel cannot discover each other.
#pragma once

#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

namespace skr::test {

inline std::string selfExe() {
  char buf[4096];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return {};
  return std::string(buf, static_cast<std::size_t>(n));
}

// Brings `lo` up in the new namespace (ip link set lo up, without the ip tool).
inline bool loopbackUp() {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return false;
  ifreq req{};
  std::strncpy(req.ifr_name, "lo", IFNAMSIZ - 1);
  bool ok = ioctl(fd, SIOCGIFFLAGS, &req) == 0;
  req.ifr_flags = static_cast<short>(req.ifr_flags | IFF_UP | IFF_RUNNING);
  ok = ok && ioctl(fd, SIOCSIFFLAGS, &req) == 0;
  close(fd);
  return ok;
}

// True when the caller runs inside its namespace (or only lists the tests: no namespace needed).
// False on an error (printed), after which main returns 1. `inside_env` marks the re-run.
inline bool enterOwnNetworkNamespace(int argc, char** argv, const char* inside_env) {
  const char* name = argc > 0 ? argv[0] : "test";
  bool listing = false;
  for (int i = 1; i < argc; ++i) listing |= std::string(argv[i]) == "--gtest_list_tests";
  if (listing) return true;
  if (!getenv(inside_env)) {
    // unshare(1) then env(1) then this program again, inside the new namespace.
    std::vector<std::string> args{"unshare"};
    if (geteuid() != 0) args.push_back("--map-root-user");
    args.insert(args.end(), {"--net", "env", std::string(inside_env) + "=1", selfExe()});
    for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
    std::vector<char*> exec_argv;
    for (auto& a : args) exec_argv.push_back(a.data());
    exec_argv.push_back(nullptr);
    execvp("unshare", exec_argv.data());
    std::cerr << name << ": cannot run unshare (util-linux) for a network namespace: "
              << std::strerror(errno) << "\n";
    return false;
  }
  if (!loopbackUp()) {
    std::cerr << name
              << ": cannot bring lo up in the test's network namespace: " << std::strerror(errno)
              << "\n";
    return false;
  }
  // The namespace has lo alone. (if_nameindex asks the kernel; /sys/class/net shows the
  // namespace that mounted /sys.)
  bool only_lo = true;
  struct if_nameindex* names = if_nameindex();
  for (struct if_nameindex* n = names; n && n->if_index != 0; ++n) {
    if (std::string(n->if_name) != "lo") {
      std::cerr << name << ": interface " << n->if_name << " in the test's namespace\n";
      only_lo = false;
    }
  }
  if_freenameindex(names);
  return only_lo;
}

}  // namespace skr::test
