// Small JSON helpers over jsoncpp for the module: compact text out, bounded parsing in.
#pragma once

#include <json/json.h>

#include <functional>
#include <initializer_list>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

namespace skr::wsui {

inline std::string compact(const Json::Value& v) {
  Json::StreamWriterBuilder b;
  b["indentation"] = "";
  b["emitUTF8"] = true;
  return Json::writeString(b, v);
}

// A JSON object as compact text; `edit` may add nested members.
inline std::string object(std::initializer_list<std::pair<const char*, Json::Value>> members,
                          const std::function<void(Json::Value&)>& edit = {}) {
  Json::Value v(Json::objectValue);
  for (const auto& [k, value] : members) v[k] = value;
  if (edit) edit(v);
  return compact(v);
}

inline std::string quote(const std::string& s) {
  return compact(Json::Value(s));
}

// Parses an object from a channel; false for anything else.
inline bool parseJson(std::string_view text, Json::Value& out) {
  Json::CharReaderBuilder b;
  b["stackLimit"] = 32;
  const std::unique_ptr<Json::CharReader> reader(b.newCharReader());
  std::string errors;
  try {
    return reader->parse(text.data(), text.data() + text.size(), &out, &errors) && out.isObject();
  } catch (const std::exception&) {  // jsoncpp throws past its nesting limit
    return false;
  }
}

}  // namespace skr::wsui
