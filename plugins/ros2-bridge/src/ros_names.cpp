// SPDX-License-Identifier: Apache-2.0
#include "ros_names.h"

namespace skr::ros2_bridge {
namespace {

bool isAlpha(char c) noexcept {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}
bool isDigit(char c) noexcept {
  return c >= '0' && c <= '9';
}

Error bad(std::string_view name, std::string why) {
  return makeError(Errc::invalid_argument,
                   "ROS name \"" + std::string(name) + "\": " + std::move(why));
}

// An absolute name ("/" alone for the root namespace) by ROS 2's token rules.
Result<void> checkAbsolute(std::string_view original, std::string_view name) {
  if (name.empty() || name.front() != '/') return bad(original, "not absolute");
  if (name == "/") return {};
  if (name.back() == '/') return bad(original, "ends with '/'");
  if (name.find("__") != std::string_view::npos) return bad(original, "contains \"__\"");
  std::size_t start = 1;
  while (start <= name.size()) {
    std::size_t end = name.find('/', start);
    if (end == std::string_view::npos) end = name.size();
    std::string_view token = name.substr(start, end - start);
    if (token.empty()) return bad(original, "contains \"//\"");
    if (isDigit(token.front())) {
      return bad(original, "token \"" + std::string(token) + "\" starts with a digit");
    }
    for (char c : token) {
      if (!isAlpha(c) && !isDigit(c) && c != '_') {
        return bad(original, "character '" + std::string(1, c) + "' not allowed");
      }
    }
    start = end + 1;
  }
  return {};
}

}  // namespace

Result<std::string> resolveRosName(std::string_view name, std::string_view ns,
                                   std::string_view node) {
  if (name.empty()) return bad(name, "empty");
  if (auto ok = checkAbsolute(ns, ns); !ok) {
    return makeError(Errc::invalid_argument, "namespace: " + ok.error().message);
  }
  std::string prefix = ns == "/" ? std::string() : std::string(ns);
  std::string resolved;
  if (name.front() == '/') {
    resolved = std::string(name);
  } else if (name.front() == '~') {
    if (node.empty()) return bad(name, "'~' needs a node name");
    if (name.size() > 1 && name[1] != '/') return bad(name, "'~' must be followed by '/'");
    resolved = prefix + "/" + std::string(node) + std::string(name.substr(1));
  } else {
    resolved = prefix + "/" + std::string(name);
  }
  if (resolved == "/") return bad(name, "names nothing");
  if (auto ok = checkAbsolute(name, resolved); !ok) return ok.error();
  return resolved;
}

Result<std::string> ddsTopicName(std::string_view ros_name, std::string_view ns,
                                 std::string_view node) {
  auto resolved = resolveRosName(ros_name, ns, node);
  if (!resolved) return resolved.error();
  std::string dds = "rt" + *resolved;
  if (dds.size() > kMaxDdsNameLength) {
    return bad(ros_name, "its DDS name has " + std::to_string(dds.size()) +
                             " characters (at most " + std::to_string(kMaxDdsNameLength) + ")");
  }
  return dds;
}

Result<std::string> rosNameForChannel(std::string_view tmpl, std::string_view channel,
                                      std::string_view ns, std::string_view node) {
  const std::size_t dot = channel.find('.');
  std::string owner(channel.substr(0, dot));
  std::string name(dot == std::string_view::npos ? std::string_view() : channel.substr(dot + 1));
  for (char& c : owner) c = c == '-' ? '_' : c;
  for (char& c : name) c = c == '-' ? '_' : c == '.' ? '/' : c;
  std::string out;
  for (std::size_t i = 0; i < tmpl.size();) {
    if (tmpl.substr(i).starts_with("{owner}")) {
      out += owner;
      i += 7;
    } else if (tmpl.substr(i).starts_with("{name}")) {
      out += name;
      i += 6;
    } else {
      out.push_back(tmpl[i++]);
    }
  }
  auto resolved = resolveRosName(out, ns, node);
  if (!resolved) return resolved.error();
  if (auto dds = ddsTopicName(*resolved); !dds) return dds.error();
  return resolved;
}

Result<std::pair<std::string, std::string>> ddsServiceTopics(std::string_view ros_name,
                                                             std::string_view ns,
                                                             std::string_view node) {
  auto resolved = resolveRosName(ros_name, ns, node);
  if (!resolved) return resolved.error();
  std::pair<std::string, std::string> out{"rq" + *resolved + "Request", "rr" + *resolved + "Reply"};
  if (out.first.size() > kMaxDdsNameLength) {
    return bad(ros_name, "its DDS name has " + std::to_string(out.first.size()) +
                             " characters (at most " + std::to_string(kMaxDdsNameLength) + ")");
  }
  return out;
}

}  // namespace skr::ros2_bridge
