// SPDX-License-Identifier: Apache-2.0
// ROS 2 definitions (plugin-api/ros2/definitions.cpp) on arbitrary text: a `.msg`, a `.srv` and
// an MCAP `ros2msg` schema (its sections), then the registry's resolution and schema text,
// whose parse must give the same types again.
#include <skrobot/ros2/definitions.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  namespace ros2 = skr::ros2;
  (void)ros2::parseMessage("fuzz/msg/M", text);
  (void)ros2::parseService("fuzz/srv/S", text);
  ros2::Registry r;
  if (!r.addSchema("fuzz/msg/M", text) || !r.resolve("fuzz/msg/M")) return 0;
  ros2::Registry again;
  if (!again.addSchema("fuzz/msg/M", r.schemaText("fuzz/msg/M"))) std::abort();
  if (again.size() != r.size()) std::abort();
  return 0;
}
