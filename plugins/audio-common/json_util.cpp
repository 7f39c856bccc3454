#include "json_util.hpp"

#include <json/reader.h>
#include <json/writer.h>

#include <cmath>
#include <memory>

namespace skr::audio {

std::optional<Json::Value> parseJson(std::string_view text) {
  Json::CharReaderBuilder builder;
  const std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value out;
  std::string errors;
  try {
    if (!reader->parse(text.data(), text.data() + text.size(), &out, &errors)) return std::nullopt;
  } catch (const std::exception&) {  // jsoncpp throws past its nesting limit
    return std::nullopt;
  }
  return out;
}

std::string toJsonText(const Json::Value& value) {
  Json::StreamWriterBuilder builder;
  builder["indentation"] = "";
  builder["emitUTF8"] = true;
  builder["precision"] = 6;
  return Json::writeString(builder, value);
}

std::string errorJson(const std::string& message) {
  Json::Value v(Json::objectValue);
  v["error"] = message;
  return toJsonText(v);
}

double rounded(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

}  // namespace skr::audio
