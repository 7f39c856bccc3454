// SPDX-License-Identifier: Apache-2.0
// ros2-bridge's config (docs/ros2.md, "The bridge"): the DDS participant's domain, interfaces
// and peers, the interface folders, and the topics imported (ROS 2 -> a channel of the module)
// and exported (a channel -> ROS 2). Every problem is reported with its key's path, all at once.
#pragma once

#include "dds_participant.h"
#include "graph_info.h"

#include <json/value.h>

#include <cstdint>
#include <string>
#include <vector>

namespace skr::ros2_bridge {

// How a channel carries a topic's messages: the CDR samples as they are (`cdr`, typed cdr/ros2msg),
// converted field by field to and from JSON (`json`), or, for sensor_msgs Image and
// CompressedImage, as the hub's media frames (`media`: raw pixels and JPEG; skrobot/ros2/images.h).
enum class Encoding : std::uint8_t { cdr, json, media };
[[nodiscard]] std::string_view encodingName(Encoding e);

struct TopicItem {
  std::string ros;      // the ROS name, resolved ("/scan")
  std::string type;     // "sensor_msgs/msg/LaserScan"
  std::string channel;  // import: the module's channel short name; export: a full channel name
  Encoding encoding = Encoding::cdr;
  Qos qos;
  std::string frame_id;  // media exports: the header's frame_id (by default the channel's name)
};

// A ROS 2 service: exported, a hub service channel (`channel`, full name) answers ROS 2 clients
// (each request is `command` with the request's fields as its JSON value); imported, a service
// channel of the module (`channel`, short name) calls a ROS 2 server.
struct ServiceItem {
  std::string ros;   // "/add_two_ints"
  std::string type;  // "example_interfaces/srv/AddTwoInts"
  std::string channel;
  std::string command;  // exports: the command the hub service gets
  std::int64_t timeout_ms = 5000;
};

struct BridgeConfig {
  ParticipantConfig participant;
  Distribution distribution = Distribution::jazzy;  // the graph information's layout
  std::string node = "skrobot";
  std::string ns = "/";
  std::vector<std::string> definitions;  // folders of interface packages, after the shipped ones
  std::vector<TopicItem> imports, exports;
  // Exports whose `channel` is a name pattern (docs/flow-protocol.md, "Channel-name patterns")
  // and whose `ros` a template with {owner} and {name} (rosNameForChannel): each channel that
  // matches, while it exists, is exported as an item of its own.
  std::vector<TopicItem> export_patterns;
  std::vector<ServiceItem> service_imports, service_exports;
  std::size_t queue_bytes = 64u << 20;  // samples waiting between the loop and the DDS thread
};

struct ConfigProblem {
  std::string key;  // "import[2].qos.depth"
  std::string reason;
};

// `domain_env`: ROS_DOMAIN_ID's value (nullptr when unset), for "domain": -1.
[[nodiscard]] std::vector<ConfigProblem> readConfig(const Json::Value& config,
                                                    const char* domain_env, BridgeConfig& out);

// "/camera/image/compressed" -> "camera.image.compressed": an import's channel by default.
[[nodiscard]] std::string channelForRosName(std::string_view ros);

}  // namespace skr::ros2_bridge
