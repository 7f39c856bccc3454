// SPDX-License-Identifier: Apache-2.0
// ROS 2 images as media frames (plugin-api/ros2/images.cpp) on arbitrary bytes: the first byte
// picks sensor_msgs/msg/Image or CompressedImage, the rest is the sample. A sample that converts
// is one the generic decoder accepts too, and its frame converts back to a sample that gives the
// same frame again.
#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>
#include <skrobot/ros2/images.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

namespace {

constexpr const char* kHeader =
    "================================================================================\n"
    "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    "================================================================================\n"
    "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";

const skr::ros2::Registry& registry() {
  static const skr::ros2::Registry r = [] {
    skr::ros2::Registry out;
    const std::string image =
        std::string(
            "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
            "uint8 is_bigendian\nuint32 step\nuint8[] data\n") +
        kHeader;
    const std::string compressed =
        std::string("std_msgs/Header header\nstring format\nuint8[] data\n") + kHeader;
    if (!out.addSchema(std::string(skr::ros2::kImageType), image) ||
        !out.addSchema(std::string(skr::ros2::kCompressedImageType), compressed)) {
      std::abort();
    }
    return out;
  }();
  return r;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view type =
      data[0] % 2 == 0 ? skr::ros2::kImageType : skr::ros2::kCompressedImageType;
  const std::string_view sample(reinterpret_cast<const char*>(data) + 1, size - 1);
  auto frame = skr::ros2::imageToFrame(type, sample, 7, 1);
  if (!frame) return 0;
  if (!skr::ros2::validate(registry(), type, sample)) std::abort();
  auto back = skr::ros2::frameToImage(type, *frame, "camera", 2);
  if (!back || !skr::ros2::validate(registry(), type, *back)) std::abort();
  auto again = skr::ros2::imageToFrame(type, *back, 7, 3);
  if (!again || *again != *frame) std::abort();
  return 0;
}
