// JSON text in and out for service requests and published results (jsoncpp).
#pragma once

#include <json/value.h>

#include <optional>
#include <string>
#include <string_view>

namespace skr::audio {

// Parses JSON text; nullopt when it is not valid JSON.
std::optional<Json::Value> parseJson(std::string_view text);
// Compact one-line JSON text, UTF-8 unescaped.
std::string toJsonText(const Json::Value& value);
// {"error": message}
std::string errorJson(const std::string& message);
// A number rounded to `decimals` places, for compact published arrays.
double rounded(double value, int decimals);

}  // namespace skr::audio
