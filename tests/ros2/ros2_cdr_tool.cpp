// SPDX-License-Identifier: Apache-2.0
// The ROS 2 types library (plugin-api/ros2) for tests/ros2/cdr_reference.test.mjs, which checks
// it against the npm reference implementations: one JSON request a line on stdin, one JSON answer
// a line on stdout.
//
//   ros2_cdr_tool FOLDER...      interface packages to load (the shipped ones first)
//
//   {"op":"types"}                               {"types":["builtin_interfaces/msg/Time",...]}
//   {"op":"schema","type":T}                     {"schema":"<ros2msg text>"}
//   {"op":"encode","type":T,"value":{...}}       {"hex":"0001..."}
//   {"op":"decode","type":T,"hex":"0001..."}     {"value":{...}}
//   anything refused                             {"error":"<why>"}
#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>
#include <skrobot/support/json.hpp>

#include <iostream>
#include <string>

namespace {

namespace ros2 = skr::ros2;

std::string hex(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (unsigned char c : bytes) {
    out.push_back(kDigits[c >> 4]);
    out.push_back(kDigits[c & 15]);
  }
  return out;
}

std::string unhex(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i + 1 < text.size(); i += 2) {
    out.push_back(static_cast<char>(std::stoi(text.substr(i, 2), nullptr, 16)));
  }
  return out;
}

Json::Value answer(const ros2::Registry& registry, const Json::Value& request) {
  Json::Value out(Json::objectValue);
  const std::string op = request["op"].asString();
  const std::string type = request["type"].asString();
  if (op == "types") {
    out["types"] = Json::Value(Json::arrayValue);
    for (const auto& name : registry.names()) out["types"].append(name);
  } else if (op == "schema") {
    if (auto r = registry.resolve(type); !r) {
      out["error"] = r.error().message;
    } else {
      out["schema"] = registry.schemaText(type);
    }
  } else if (op == "encode") {
    auto cdr = ros2::jsonToCdr(registry, type, request["value"]);
    if (cdr) {
      out["hex"] = hex(*cdr);
    } else {
      out["error"] = cdr.error().message;
    }
  } else if (op == "decode") {
    auto value = ros2::cdrToJson(registry, type, unhex(request["hex"].asString()));
    if (value) {
      out["value"] = *value;
    } else {
      out["error"] = value.error().message;
    }
  } else {
    out["error"] = "no such op: " + op;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  ros2::Registry registry;
  for (int i = 1; i < argc; ++i) {
    if (auto r = registry.addFolder(argv[i]); !r) {
      std::cerr << "ros2_cdr_tool: " << r.error().message << "\n";
      return 1;
    }
  }
  std::string line;
  while (std::getline(std::cin, line)) {
    auto request = skr::support::parseJson(line);
    Json::Value out(Json::objectValue);
    if (!request) {
      out["error"] = "not JSON: " + request.error().message;
    } else {
      out = answer(registry, *request);
    }
    std::cout << skr::support::writeJson(out) << std::endl;
  }
  return 0;
}
