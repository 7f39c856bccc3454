// SPDX-License-Identifier: Apache-2.0
// CDR samples (plugin-api/ros2/cdr.cpp) of a few ROS 2 types on arbitrary bytes: the first byte
// picks the type, the rest is the sample. A sample that decodes encodes again; from there the
// round trip is exact (the first one may differ: big-endian input, a NaN read as null and written
// as 0, padding bytes that were not 0).
#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

namespace {

constexpr std::array<std::pair<const char*, const char*>, 4> kTypes = {{
    {"geometry_msgs/msg/Twist",
     "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n"
     "================================================================================\n"
     "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"},
    {"lab/msg/Mixed",
     "uint8 a\nfloat64 b\nstring name\nint16[] xs\nbool[2] flags\nstring<=5 tag\n"
     "lab/Inner[<=3] inner\n"
     "================================================================================\n"
     "MSG: lab/Inner\nint64 n\nstring[] words\nuint8[] data\n"},
    {"sensor_msgs/msg/JointState",
     "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
     "float64[] effort\n"
     "================================================================================\n"
     "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
     "================================================================================\n"
     "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"},
    {"std_srvs/srv/Trigger_Request", ""},
}};

const skr::ros2::Registry& registry() {
  static const skr::ros2::Registry r = [] {
    skr::ros2::Registry out;
    for (const auto& [name, text] : kTypes) {
      if (!out.addSchema(name, text)) std::abort();
    }
    return out;
  }();
  return r;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const char* type = kTypes[data[0] % kTypes.size()].first;
  const std::string_view sample(reinterpret_cast<const char*>(data) + 1, size - 1);
  auto json = skr::ros2::cdrToJson(registry(), type, sample);
  // validate() (what ros2-bridge checks samples with) judges every sample as cdrToJson does.
  if (static_cast<bool>(skr::ros2::validate(registry(), type, sample)) != static_cast<bool>(json)) {
    std::abort();
  }
  if (!json) return 0;
  auto cdr = skr::ros2::jsonToCdr(registry(), type, *json);
  if (!cdr) std::abort();  // what was read can be written
  auto json2 = skr::ros2::cdrToJson(registry(), type, *cdr);
  if (!json2) std::abort();
  auto cdr2 = skr::ros2::jsonToCdr(registry(), type, *json2);
  if (!cdr2 || *cdr2 != *cdr) std::abort();
  return 0;
}
