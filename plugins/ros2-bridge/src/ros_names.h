// SPDX-License-Identifier: Apache-2.0
// ROS 2 names as DDS names (ROS 2 design, "Topic and Service name mapping to DDS"): a topic
// "/a/b" is the DDS topic "rt/a/b". No Fast DDS here.
#pragma once

#include <skrobot/result.hpp>

#include <string>
#include <string_view>
#include <utility>

namespace skr::ros2_bridge {

// DDS limits a topic name to 256 characters; ROS 2 keeps its names under that.
inline constexpr std::size_t kMaxDdsNameLength = 255;

// `name` resolved against `ns` (an absolute namespace, "/" by default) and `node` (for "~"):
// "chatter" in "/robot" -> "/robot/chatter", "~/status" of node "bridge" in "/" ->
// "/bridge/status". Checks ROS 2's rules: tokens [A-Za-z_][A-Za-z0-9_]*, separated by single
// '/', no "__", no trailing '/'. Errc::invalid_argument naming what is wrong.
[[nodiscard]] Result<std::string> resolveRosName(std::string_view name, std::string_view ns = "/",
                                                 std::string_view node = {});
// The DDS topic of a ROS topic: "/chatter" -> "rt/chatter" (resolved as above; its length
// checked against kMaxDdsNameLength).
[[nodiscard]] Result<std::string> ddsTopicName(std::string_view ros_name, std::string_view ns = "/",
                                               std::string_view node = {});

// An export pattern's ROS name for one of the channels it matches: `{owner}` in `tmpl` is the
// channel's owner (before its first '.', a linked hub's prefix included), `{name}` its short name
// with '.' as '/'; '-' (allowed in channel names, not in ROS names) becomes '_'. The result is
// resolved as above: "/hub/{owner}/{name}" for "guest.arm.cmd" -> "/hub/guest/arm/cmd".
[[nodiscard]] Result<std::string> rosNameForChannel(std::string_view tmpl, std::string_view channel,
                                                    std::string_view ns = "/",
                                                    std::string_view node = {});

// The request and reply topics of a ROS service: "/add" -> "rq/addRequest", "rr/addReply".
[[nodiscard]] Result<std::pair<std::string, std::string>> ddsServiceTopics(
    std::string_view ros_name, std::string_view ns = "/", std::string_view node = {});

}  // namespace skr::ros2_bridge
