// SPDX-License-Identifier: Apache-2.0
// ROS 2's graph information (rmw_dds_common, design "Node to Participant mapping"): each
// participant publishes on the DDS topic ros_discovery_info which nodes it holds and the GUIDs of
// their readers and writers; `ros2 node list` and `ros2 node info` are made from it. A GUID
// ("gid") is 24 bytes in Humble (16 of GUID, zeros) and 16 from Iron on: the distribution says
// which. No Fast DDS here.
#pragma once

#include "dds_participant.h"

#include <string>
#include <string_view>
#include <vector>

namespace skr::ros2_bridge {

enum class Distribution : std::uint8_t { humble, jazzy };

inline constexpr const char* kGraphTopic = "ros_discovery_info";
inline constexpr const char* kGraphType = "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_";
inline constexpr const char* kGraphRosType = "rmw_dds_common/msg/ParticipantEntitiesInfo";

// The rmw_dds_common definitions of `d` (Gid, NodeEntitiesInfo, ParticipantEntitiesInfo), as a
// ros2msg schema of kGraphRosType: for a Registry (addSchema), to read or write the topic.
[[nodiscard]] std::string graphSchema(Distribution d);

// The one node of a participant: its sample on ros_discovery_info (CDR).
[[nodiscard]] std::string participantEntitiesInfo(Distribution d, const Gid& participant,
                                                  std::string_view node_namespace,
                                                  std::string_view node_name,
                                                  const std::vector<Gid>& readers,
                                                  const std::vector<Gid>& writers);

// The graph topic's QoS in rmw_fastrtps: reliable, transient_local, keep_last 1.
[[nodiscard]] Qos graphQos();

}  // namespace skr::ros2_bridge
