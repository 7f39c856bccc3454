// SPDX-License-Identifier: Apache-2.0
#include "ros2_messages.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/support/json.hpp>

namespace flowctl::ros2msg {

namespace ct = skr::channel_type;
namespace ros2 = skr::ros2;

skr::Result<ros2::Registry> shippedRegistry(const std::vector<std::string>& folders) {
  ros2::Registry registry;
  const auto shipped = ros2::shippedFolder();
  if (!shipped.empty()) {
    if (auto r = registry.addFolder(shipped); !r) return r.error();
  }
  for (const auto& folder : folders) {
    if (auto r = registry.addFolder(folder); !r) return r.error();
  }
  return registry;
}

std::optional<CdrReader> CdrReader::of(const ct::ChannelType& type, std::string& why) {
  if (type.message_encoding != "cdr") return std::nullopt;
  CdrReader reader;
  reader.type_ = ros2::fullName(type.schema_name).value_or(type.schema_name);
  if (type.schema_encoding == "ros2msg" && !type.schema.empty()) {
    if (auto r = reader.registry_.addSchema(type.schema_name, type.schema); !r) {
      why = "its ros2msg schema: " + r.error().message;
      return std::nullopt;
    }
  } else if (auto shipped = shippedRegistry()) {
    reader.registry_ = std::move(*shipped);
  }
  if (auto r = reader.registry_.resolve(reader.type_); !r) {
    why = type.schema_name.empty() ? "a cdr channel without a schema name" : r.error().message;
    return std::nullopt;
  }
  return reader;
}

skr::Result<Json::Value> CdrReader::read(std::string_view sample) const {
  return ros2::cdrToJson(registry_, type_, sample);
}

skr::Result<Encoded> encode(const ros2::Registry& registry, std::string_view type,
                            std::string_view json) {
  const auto name = ros2::fullName(type);
  if (!name) {
    return skr::makeError(skr::Errc::invalid_argument,
                          std::string(type) + " is not a ROS 2 type name (pkg/msg/Name)");
  }
  if (auto r = registry.resolve(*name); !r) return r.error();
  auto value = skr::support::parseJson(json);
  if (!value) {
    return skr::makeError(skr::Errc::invalid_argument,
                          "the payload must be JSON: " + value.error().message);
  }
  auto sample = ros2::jsonToCdr(registry, *name, *value);
  if (!sample) return sample.error();
  return Encoded{std::move(*sample), {"cdr", *name, "ros2msg", registry.schemaText(*name)}};
}

}  // namespace flowctl::ros2msg
