// SPDX-License-Identifier: Apache-2.0
#include "graph_info.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>

#include <stdexcept>

namespace skr::ros2_bridge {

std::string graphSchema(Distribution d) {
  const std::string sep =
      "================================================================================\n";
  return "Gid gid\nNodeEntitiesInfo[] node_entities_info_seq\n" + sep +
         "MSG: rmw_dds_common/NodeEntitiesInfo\nstring<=256 node_namespace\n"
         "string<=256 node_name\nGid[] reader_gid_seq\nGid[] writer_gid_seq\n" +
         sep + "MSG: rmw_dds_common/Gid\n" +
         (d == Distribution::humble ? "char[24] data\n" : "char[16] data\n");
}

std::string participantEntitiesInfo(Distribution d, const Gid& participant,
                                    std::string_view node_namespace, std::string_view node_name,
                                    const std::vector<Gid>& readers,
                                    const std::vector<Gid>& writers) {
  static const ros2::Registry humble = [] {
    ros2::Registry r;
    if (!r.addSchema(kGraphRosType, graphSchema(Distribution::humble))) {
      throw std::logic_error("graph schema");
    }
    return r;
  }();
  static const ros2::Registry jazzy = [] {
    ros2::Registry r;
    if (!r.addSchema(kGraphRosType, graphSchema(Distribution::jazzy))) {
      throw std::logic_error("graph schema");
    }
    return r;
  }();
  const std::size_t size = d == Distribution::humble ? 24 : 16;
  auto gid = [size](const Gid& g) {
    Json::Value data(Json::arrayValue);
    for (std::size_t i = 0; i < size; ++i) data.append(i < g.size() ? g[i] : 0);
    Json::Value out(Json::objectValue);
    out["data"] = std::move(data);
    return out;
  };
  Json::Value node(Json::objectValue);
  node["node_namespace"] = std::string(node_namespace);
  node["node_name"] = std::string(node_name);
  node["reader_gid_seq"] = Json::Value(Json::arrayValue);
  node["writer_gid_seq"] = Json::Value(Json::arrayValue);
  for (const Gid& g : readers) node["reader_gid_seq"].append(gid(g));
  for (const Gid& g : writers) node["writer_gid_seq"].append(gid(g));
  Json::Value info(Json::objectValue);
  info["gid"] = gid(participant);
  info["node_entities_info_seq"].append(std::move(node));
  auto cdr = ros2::jsonToCdr(d == Distribution::humble ? humble : jazzy, kGraphRosType, info);
  if (!cdr) throw std::invalid_argument(cdr.error().message);  // a node name over 256 bytes
  return std::move(*cdr);
}

Qos graphQos() {
  Qos q;
  q.reliability = Reliability::reliable;
  q.durability = Durability::transient_local;
  q.history = History::keep_last;
  q.depth = 1;
  return q;
}

}  // namespace skr::ros2_bridge
