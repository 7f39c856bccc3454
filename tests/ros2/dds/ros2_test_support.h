// SPDX-License-Identifier: Apache-2.0
// What the DDS tests share (header-only): the shipped ROS 2 interfaces, JSON and CDR from text,
// the multicast groups this network namespace joined, and main() in a namespace of its own
// (own_netns.h).
#pragma once

#include "own_netns.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>
#include <skrobot/support/json.hpp>

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace skr::ros2::test {

// The interfaces shipped with the project, as the build tree holds them.
inline const Registry& shipped() {
  static const Registry r = [] {
    Registry out;
    if (auto loaded = out.addFolder(shippedFolder()); !loaded) {
      ADD_FAILURE() << loaded.error().message;
    }
    return out;
  }();
  return r;
}

inline Json::Value json(std::string_view text) {
  auto v = skr::support::parseJson(text);
  EXPECT_TRUE(v) << text.substr(0, 200);
  return v ? *v : Json::Value();
}

// A sample of `type` from its JSON value (parsed, or text), with the shipped definitions.
inline std::string cdrOf(std::string_view type, const Json::Value& value) {
  auto bytes = jsonToCdr(shipped(), type, value);
  EXPECT_TRUE(bytes) << bytes.error().message;
  return bytes ? *bytes : std::string();
}
inline std::string cdr(std::string_view type, std::string_view value) {
  return cdrOf(type, json(value));
}

// Multicast groups joined in this network namespace (/proc/net/igmp), other than all-hosts.
inline std::vector<std::string> multicastGroups() {
  std::vector<std::string> groups;
  std::ifstream in("/proc/net/igmp");
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string first;
    words >> first;
    if (first.size() != 8) continue;  // group lines start with the group in hex
    in_addr addr{};
    // /proc shows it in network order, as read on a little-endian host.
    addr.s_addr = static_cast<std::uint32_t>(std::stoul(first, nullptr, 16));
    char text[INET_ADDRSTRLEN];
    inet_ntop(AF_INET, &addr, text, sizeof text);
    if (std::string(text) != "224.0.0.1") groups.push_back(text);
  }
  return groups;
}

// main() of a DDS test program: its tests run in a network namespace of their own.
inline int runInOwnNamespace(int argc, char** argv) {
  if (const int failed = skr::test::enterOwnNetworkNamespace(argc, argv); failed != 0) {
    return failed;
  }
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

}  // namespace skr::ros2::test
