// SPDX-License-Identifier: Apache-2.0
#include "foxglove_convert.h"

#include <skrobot/media_frame.hpp>
#include <skrobot/support/json.hpp>

namespace skr::foxglove {
namespace {

using skr::support::writeJson;

// Detections are small objects; anything deeper or larger is not one.
constexpr skr::support::JsonLimits kDetectionLimits{16, 4u << 20};

// The foxglove.* schemas, written for the fields this bridge fills (the field names and
// required lists of @foxglove/schemas 2.1.0; tests/foxglove checks them against it).
constexpr const char* kColorSchema =
    R"({"type":"object","properties":{"r":{"type":"number"},"g":{"type":"number"},)"
    R"("b":{"type":"number"},"a":{"type":"number"}}})";
constexpr const char* kPoint2Schema =
    R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"}}})";

std::string imageAnnotationsSchema() {
  const std::string color = kColorSchema;
  const std::string point = kPoint2Schema;
  const std::string time(timeSchema());
  const std::string circle =
      R"({"type":"object","properties":{"timestamp":)" + time + R"(,"position":)" + point +
      R"(,"diameter":{"type":"number"},"thickness":{"type":"number"},"fill_color":)" + color +
      R"(,"outline_color":)" + color +
      R"(},"required":["timestamp","position","diameter","thickness","fill_color",)"
      R"("outline_color"]})";
  const std::string points =
      R"({"type":"object","properties":{"timestamp":)" + time +
      R"(,"type":{"type":"integer","enum":[0,1,2,3,4]},"points":{"type":"array","items":)" + point +
      R"(},"outline_color":)" + color + R"(,"outline_colors":{"type":"array","items":)" + color +
      R"(},"fill_color":)" + color +
      R"(,"thickness":{"type":"number"}},"required":["timestamp","type","points",)"
      R"("outline_color","outline_colors","fill_color","thickness"]})";
  const std::string text =
      R"({"type":"object","properties":{"timestamp":)" + time + R"(,"position":)" + point +
      R"(,"text":{"type":"string"},"font_size":{"type":"number"},"text_color":)" + color +
      R"(,"background_color":)" + color +
      R"(},"required":["timestamp","position","text","font_size","text_color",)"
      R"("background_color"]})";
  return R"({"title":"foxglove.ImageAnnotations","type":"object","properties":{"circles":)"
         R"({"type":"array","items":)" +
         circle + R"(},"points":{"type":"array","items":)" + points +
         R"(},"texts":{"type":"array","items":)" + text +
         R"(}},"required":["circles","points","texts"]})";
}

Json::Value timeOf(std::int64_t ns) {
  Json::Value t(Json::objectValue);
  if (ns < 0) ns = 0;
  t["sec"] = static_cast<Json::UInt64>(ns / 1000000000);
  t["nsec"] = static_cast<Json::UInt64>(ns % 1000000000);
  return t;
}

Json::Value color(double r, double g, double b, double a) {
  Json::Value c(Json::objectValue);
  c["r"] = r;
  c["g"] = g;
  c["b"] = b;
  c["a"] = a;
  return c;
}

Json::Value point(double x, double y) {
  Json::Value p(Json::objectValue);
  p["x"] = x;
  p["y"] = y;
  return p;
}

}  // namespace

std::string schemaName(Shape shape, const std::string& mime) {
  switch (shape) {
    case Shape::image:
      return "foxglove.CompressedImage";
    case Shape::raw_image:
      return "foxglove.RawImage";
    case Shape::annotations:
      return "foxglove.ImageAnnotations";
    case Shape::joints:
      return "skrobot.JointPositions";
    case Shape::json:
    case Shape::typed:  // its own name: the channel's schema_name
      break;
  }
  return mime;
}

std::string schemaText(Shape shape) {
  switch (shape) {
    case Shape::image:
      return compressedImageSchema();
    case Shape::raw_image:
      return rawImageSchema();
    case Shape::annotations:
      return imageAnnotationsSchema();
    case Shape::joints:
      return R"({"type":"object","properties":{"angles":{"type":"array","items":)"
             R"({"type":"number"}},"positions":{"type":"object",)"
             R"("additionalProperties":{"type":"number"}}}})";
    case Shape::json:
    case Shape::typed:  // its own text: the channel's schema
      break;
  }
  return R"({"type":"object"})";
}

std::optional<Converted> imageAnnotations(std::string_view message) {
  auto parsed = skr::support::parseJsonObject(message, kDetectionLimits);
  if (!parsed) return std::nullopt;
  const Json::Value& in = *parsed;
  const bool faces = in["faces"].isArray();
  const Json::Value& boxes = faces ? in["faces"] : in["regions"];
  if (!boxes.isArray()) return std::nullopt;
  const std::int64_t ns = in["capture_ns"].isIntegral() ? in["capture_ns"].asInt64() : 0;
  const Json::Value time = timeOf(ns);
  const Json::Value outline = faces ? color(0.2, 0.9, 0.3, 1.0) : color(1.0, 0.6, 0.1, 1.0);
  Json::Value out(Json::objectValue);
  out["circles"] = Json::Value(Json::arrayValue);
  out["points"] = Json::Value(Json::arrayValue);
  out["texts"] = Json::Value(Json::arrayValue);
  for (const Json::Value& b : boxes) {
    if (!b.isObject() || !b["x"].isNumeric() || !b["y"].isNumeric() || !b["w"].isNumeric() ||
        !b["h"].isNumeric()) {
      continue;
    }
    const double x = b["x"].asDouble(), y = b["y"].asDouble();
    const double w = b["w"].asDouble(), h = b["h"].asDouble();
    Json::Value loop(Json::objectValue);
    loop["timestamp"] = time;
    loop["type"] = 2;  // LINE_LOOP
    loop["points"].append(point(x, y));
    loop["points"].append(point(x + w, y));
    loop["points"].append(point(x + w, y + h));
    loop["points"].append(point(x, y + h));
    loop["outline_color"] = outline;
    loop["outline_colors"] = Json::Value(Json::arrayValue);
    loop["fill_color"] = color(0, 0, 0, 0);
    loop["thickness"] = 2.0;
    out["points"].append(std::move(loop));
    if (b["score"].isNumeric()) {
      Json::Value t(Json::objectValue);
      t["timestamp"] = time;
      t["position"] = point(x, y);
      char score[32];
      std::snprintf(score, sizeof score, "%.2f", b["score"].asDouble());
      t["text"] = score;
      t["font_size"] = 12.0;
      t["text_color"] = color(1, 1, 1, 1);
      t["background_color"] = color(0, 0, 0, 0.6);
      out["texts"].append(std::move(t));
    }
  }
  if (!faces && in["center"].isObject() && in["center"]["x"].isNumeric() &&
      in["center"]["y"].isNumeric()) {
    Json::Value c(Json::objectValue);
    c["timestamp"] = time;
    c["position"] = point(in["center"]["x"].asDouble(), in["center"]["y"].asDouble());
    c["diameter"] = 8.0;
    c["thickness"] = 2.0;
    c["fill_color"] = outline;
    c["outline_color"] = outline;
    out["circles"].append(std::move(c));
  }
  return Converted{writeJson(out), static_cast<std::uint64_t>(std::max<std::int64_t>(ns, 0))};
}

std::optional<Converted> jointPositions(std::string_view message,
                                        const std::vector<std::string>& names) {
  auto parsed = skr::support::parseJsonObject(message, kDetectionLimits);
  if (!parsed || !(*parsed)["angles"].isArray()) return std::nullopt;
  Json::Value out = *parsed;
  Json::Value& positions = out["positions"] = Json::Value(Json::objectValue);
  const Json::Value& angles = (*parsed)["angles"];
  for (Json::ArrayIndex i = 0; i < angles.size() && i < names.size(); ++i) {
    if (angles[i].isNumeric()) positions[names[i]] = angles[i].asDouble();
  }
  return Converted{writeJson(out), 0};
}

}  // namespace skr::foxglove
