// SPDX-License-Identifier: Apache-2.0
// DDS tests run in a network namespace of their own (docs/testing.md): nothing they send can
// leave the machine, and tests running side by side cannot discover each other's participants.
// A test program's main() calls enterOwnNetworkNamespace() first: outside a namespace it runs
// itself again under `unshare --net` (--map-root-user when not root); inside, it brings lo up
// and checks that lo is the only interface.
#pragma once

#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

namespace skr::test {

inline constexpr const char* kOwnNetnsEnv = "SKROBOT_DDS_TEST_NETNS";

inline std::string selfExe() {
  char buf[4096];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return {};
  return std::string(buf, static_cast<std::size_t>(n));
}

// Whether this process runs in the namespace enterOwnNetworkNamespace made.
inline bool inOwnNetworkNamespace() {
  return std::getenv(kOwnNetnsEnv) != nullptr;
}

// 0 when this process is inside its namespace (go on); otherwise it is replaced by the same
// program inside one, or the exit status of a failure, said on stderr. --gtest_list_tests
// (CTest's discovery) runs where it is.
inline int enterOwnNetworkNamespace(int argc, char** argv) {
  const std::string name = argc > 0 ? argv[0] : "test";
  bool listing = false;
  for (int i = 1; i < argc; ++i) listing |= std::string(argv[i]) == "--gtest_list_tests";
  if (listing) return 0;
  if (!inOwnNetworkNamespace()) {
    std::vector<std::string> args{"unshare"};
    if (geteuid() != 0) args.push_back("--map-root-user");
    args.insert(args.end(), {"--net", "env", std::string(kOwnNetnsEnv) + "=1", selfExe()});
    for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
    std::vector<char*> exec_argv;
    for (auto& a : args) exec_argv.push_back(a.data());
    exec_argv.push_back(nullptr);
    execvp("unshare", exec_argv.data());
    std::perror((name + ": cannot run unshare (util-linux) for a network namespace").c_str());
    return 1;
  }
  // lo up (ip link set lo up, without the ip tool).
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  ifreq req{};
  std::strncpy(req.ifr_name, "lo", IFNAMSIZ - 1);
  bool up = fd >= 0 && ioctl(fd, SIOCGIFFLAGS, &req) == 0;
  req.ifr_flags = static_cast<short>(req.ifr_flags | IFF_UP | IFF_RUNNING);
  up = up && ioctl(fd, SIOCSIFFLAGS, &req) == 0;
  if (fd >= 0) close(fd);
  if (!up) {
    std::perror((name + ": cannot bring lo up in the test's network namespace").c_str());
    return 1;
  }
  // lo alone: nothing sent can reach another machine. (if_nameindex asks the kernel;
  // /sys/class/net shows the namespace that mounted /sys.)
  struct if_nameindex* names = if_nameindex();
  for (struct if_nameindex* n = names; n && n->if_index != 0; ++n) {
    if (std::string(n->if_name) != "lo") {
      std::cerr << name << ": interface " << n->if_name << " in the test's namespace\n";
      if_freenameindex(names);
      return 1;
    }
  }
  if_freenameindex(names);
  return 0;
}

}  // namespace skr::test
