// SPDX-License-Identifier: Apache-2.0
// ROS 2 interface definitions at run time, without generated code (docs/ros2.md): `.msg` and
// `.srv` text parsed into message definitions, kept in a registry by their full names
// ("geometry_msgs/msg/Twist"), and written back as MCAP's `ros2msg` schema text (the main
// definition, then each type it uses after a line of '=' and "MSG: pkg/Type"). cdr.h reads and
// writes CDR samples from these definitions. No Fast DDS, no I/O but addFolder's.
//
// The grammar (ROS 2's interface definitions): one field per line, `TYPE NAME [DEFAULT]`, or a
// constant `TYPE NAME=VALUE`; `#` starts a comment. TYPE is a primitive (bool, byte, char,
// float32, float64, int8..int64, uint8..uint64, string, wstring), `string<=N`, or a message
// (`pkg/Name`, or `Name` of the same package); `[]`, `[N]` or `[<=N]` after it make an array.
#pragma once

#include <skrobot/result.hpp>

#include <json/value.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skr::ros2 {

enum class Primitive : std::uint8_t {
  boolean,
  byte,
  character,  // `char`: a uint8 in ROS 2
  float32,
  float64,
  int8,
  uint8,
  int16,
  uint16,
  int32,
  uint32,
  int64,
  uint64,
  string,
  wstring,
};

// The name a definition writes ("bool", "float64", ...), and the primitive of a name.
[[nodiscard]] std::string_view primitiveName(Primitive p) noexcept;
[[nodiscard]] std::optional<Primitive> primitiveOf(std::string_view name) noexcept;

struct FieldType {
  enum class Array : std::uint8_t { none, fixed, bounded, unbounded };
  std::optional<Primitive> primitive;  // set for primitives; else `message` names the type
  std::string message;                 // "pkg/msg/Name"
  std::uint32_t string_bound = 0;      // string<=N, wstring<=N: N (0: unbounded)
  Array array = Array::none;
  std::uint32_t array_size = 0;  // fixed: its size; bounded: the most
};

struct Field {
  std::string name;
  FieldType type;
  std::optional<Json::Value> default_value;  // as written, converted to the field's type
};

struct Constant {
  std::string name;
  Primitive type = Primitive::int32;
  Json::Value value;
};

struct MessageDefinition {
  std::string name;  // "pkg/msg/Name" (services: "pkg/srv/Name_Request", "..._Response")
  std::vector<Field> fields;
  std::vector<Constant> constants;
};

// A definition's text for the message `name` ("pkg/msg/Name"). Errors: Errc::parse_error,
// "<name>:<line>: <why>".
[[nodiscard]] Result<MessageDefinition> parseMessage(std::string_view name, std::string_view text);
// A service's text ("<request>\n---\n<response>") for `name` ("pkg/srv/Name"): its request and
// response, named "pkg/srv/Name_Request" and "pkg/srv/Name_Response".
[[nodiscard]] Result<std::pair<MessageDefinition, MessageDefinition>> parseService(
    std::string_view name, std::string_view text);

// "pkg/Name" or "pkg/msg/Name" as "pkg/msg/Name"; nullopt for anything else.
[[nodiscard]] std::optional<std::string> fullName(std::string_view name);
// The DDS type name ROS 2 gives a message: "pkg/msg/Name" -> "pkg::msg::dds_::Name_".
[[nodiscard]] std::string ddsTypeName(std::string_view full_name);

// The interface packages shipped with the project (plugin-api/ros2/msgs: builtin_interfaces,
// std_msgs, geometry_msgs, sensor_msgs, nav_msgs, tf2_msgs, diagnostic_msgs, rosgraph_msgs,
// std_srvs, example_interfaces), found from `dir`, the directory of the running program or
// module: installed (<prefix>/share/skrobot/ros2/msgs) or a build tree's copy (<build>/ros2/msgs).
// Empty when neither exists.
[[nodiscard]] std::filesystem::path shippedFolder(const std::filesystem::path& dir);
// The same from the directory of what this library is linked into: a module's .so, or the
// program (flowctl).
[[nodiscard]] std::filesystem::path shippedFolder();

class Registry {
 public:
  // Adds a definition; Errc::already_exists for a name held already with another definition.
  [[nodiscard]] Result<void> add(MessageDefinition definition);
  // Every `<root>/<package>/msg/*.msg` and `<root>/<package>/srv/*.srv` (the layout of ROS 2's
  // interface packages). Errors name the file and line.
  [[nodiscard]] Result<void> addFolder(const std::filesystem::path& root);
  // An MCAP `ros2msg` schema of `name`: its definition and those of the types it uses.
  [[nodiscard]] Result<void> addSchema(std::string_view name, std::string_view text);

  // The definition of "pkg/msg/Name" (or "pkg/Name"), or nullptr.
  [[nodiscard]] const MessageDefinition* find(std::string_view name) const;
  // Whether `name` and every type it uses, at any depth, are known: Errc::not_found naming the
  // first missing one and who uses it.
  [[nodiscard]] Result<void> resolve(std::string_view name) const;
  // The `ros2msg` schema text of `name` (resolve() first).
  [[nodiscard]] std::string schemaText(std::string_view name) const;
  [[nodiscard]] std::size_t size() const noexcept { return definitions_.size(); }
  // The full names of every definition, sorted.
  [[nodiscard]] std::vector<std::string> names() const;

 private:
  std::map<std::string, MessageDefinition, std::less<>> definitions_;
  std::map<std::string, std::string, std::less<>> texts_;  // as parsed, for schemaText
};

}  // namespace skr::ros2
