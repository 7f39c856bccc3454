// SPDX-License-Identifier: Apache-2.0
// ROS 2 definitions (plugin-api/ros2/definitions.cpp) on arbitrary text: a `.msg`, a `.srv` and
// an MCAP `ros2msg` schema (its sections), then the registry's resolution and schema text,
// which must parse again, resolve, and be written the same (the text holds the type and those it
// uses: a section that nothing uses is not written again).
#include <skrobot/ros2/definitions.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  namespace ros2 = skr::ros2;
  (void)ros2::parseMessage("fuzz/msg/M", text);
  (void)ros2::parseService("fuzz/srv/S", text);
  ros2::Registry r;
  if (!r.addSchema("fuzz/msg/M", text) || !r.resolve("fuzz/msg/M")) return 0;
  const std::string schema = r.schemaText("fuzz/msg/M");
  ros2::Registry again;
  if (!again.addSchema("fuzz/msg/M", schema) || !again.resolve("fuzz/msg/M")) std::abort();
  if (again.schemaText("fuzz/msg/M") != schema) std::abort();
  return 0;
}
