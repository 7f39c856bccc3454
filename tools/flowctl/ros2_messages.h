// SPDX-License-Identifier: Apache-2.0
// ROS 2 messages in flowctl (docs/ros2.md, "ROS 2 types without ROS"): a `cdr` channel echoed
// as JSON through its `ros2msg` schema (or the shipped definition of its schema name), and JSON
// published as CDR of a ROS 2 type (pub --ros2-type) with the type in the channel's properties.
#pragma once

#include <skrobot/ros2/definitions.h>
#include <skrobot/channel_type.hpp>
#include <skrobot/result.hpp>

#include <json/value.h>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace flowctl::ros2msg {

// The interfaces shipped with the project (found beside flowctl) and those of `folders`.
[[nodiscard]] skr::Result<skr::ros2::Registry> shippedRegistry(
    const std::vector<std::string>& folders = {});

// Reads the samples of one typed channel.
class CdrReader {
 public:
  // For a `cdr` channel whose type is known: its schema text, else the shipped definition of its
  // schema name. nullopt for any other channel; with `why` set when a cdr channel's type is not
  // known (the samples are then shown as bytes).
  static std::optional<CdrReader> of(const skr::channel_type::ChannelType& type, std::string& why);
  [[nodiscard]] skr::Result<Json::Value> read(std::string_view sample) const;

 private:
  skr::ros2::Registry registry_;
  std::string type_;
};

// The CDR sample of `json` (JSON text) as `type` ("pkg/msg/Name"), and the channel type that
// says so (cdr, the type's name and its ros2msg schema text).
struct Encoded {
  std::string sample;
  skr::channel_type::ChannelType type;
};
[[nodiscard]] skr::Result<Encoded> encode(const skr::ros2::Registry& registry,
                                          std::string_view type, std::string_view json);

}  // namespace flowctl::ros2msg
