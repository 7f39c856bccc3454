// SPDX-License-Identifier: Apache-2.0
// One Fast DDS data type for every ROS 2 message: samples already serialized as CDR, with their
// 4-byte encapsulation header, copied in and out as they are (rmw_fastrtps's serialized-message
// path does the same). No generated code and no dynamic types: endpoints match by type name
// alone (type objects and type information are not sent, as rmw_fastrtps). Includes Fast DDS:
// only dds_participant.cpp includes this header.
#pragma once

#include <fastdds/dds/topic/TopicDataType.hpp>

#include <cstddef>
#include <cstdint>
#include <string>

namespace skr::ros2_bridge {

// What a writer hands to DataWriter::write (a view of the caller's bytes, not copied until
// serialize) and what a reader takes into (`owned`).
struct RawCdrSample {
  const std::uint8_t* view = nullptr;
  std::size_t view_size = 0;
  std::string owned;

  [[nodiscard]] const std::uint8_t* data() const noexcept {
    return view ? view : reinterpret_cast<const std::uint8_t*>(owned.data());
  }
  [[nodiscard]] std::size_t size() const noexcept { return view ? view_size : owned.size(); }
};

class RawCdrType final : public eprosima::fastdds::dds::TopicDataType {
 public:
  // `dds_type_name`: "pkg::msg::dds_::Name_" (skr::ros2::ddsTypeName).
  explicit RawCdrType(const std::string& dds_type_name);

  // A sample of fewer than 4 bytes (no encapsulation header) or more than a payload can hold is
  // refused (false).
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override;
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override;
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override;
  void* createData() override;
  void deleteData(void* data) override;
  bool getKey(void* data, eprosima::fastrtps::rtps::InstanceHandle_t* handle,
              bool force_md5) override;
};

}  // namespace skr::ros2_bridge
