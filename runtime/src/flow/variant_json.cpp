// SPDX-License-Identifier: Apache-2.0
// The JSON mapping of Variant (docs/pair-databases.md) to and from a Json::Value. The text of
// modules' values and the protocol's "JSON twin" commands is read and written without a
// Json::Value: variant_json_read.cpp, variant_json_write.cpp.
#include "variant_json_text.h"

#include <skrobot/runtime/flow/variant.h>

#include <cmath>
#include <limits>

namespace skr::flow {
namespace {

using Type = Variant::Type;

const std::string kBase64Key(json_keys::kBase64);
const std::string kMapKey(json_keys::kMap);

Json::Value mapToJson(const Variant::Map& m) {
  Json::Value out(Json::objectValue);
  for (const auto& [key, item] : m) out[key] = item.toJson();
  return out;
}

// A string of a JSON value, embedded NULs included.
std::string_view jsonString(const Json::Value& v) {
  const char* begin = nullptr;
  const char* end = nullptr;
  if (!v.getString(&begin, &end)) return {};
  return {begin, static_cast<size_t>(end - begin)};
}

class FromJson {
 public:
  explicit FromJson(size_t max_depth) : max_depth_(max_depth) {}

  Result<Variant> value(const Json::Value& j, size_t depth, const std::string& path) {
    if (depth > max_depth_) {
      return fail(path, "nesting depth " + std::to_string(depth) + " exceeds the limit of " +
                            std::to_string(max_depth_));
    }
    switch (j.type()) {
      case Json::nullValue:
        return Variant();
      case Json::booleanValue:
        return Variant(j.asBool());
      case Json::intValue:
        return Variant(static_cast<int64_t>(j.asInt64()));
      case Json::uintValue: {
        const uint64_t u = j.asUInt64();
        if (u <= static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
          return Variant(static_cast<int64_t>(u));
        }
        return Variant(u);
      }
      case Json::realValue:
        return Variant(j.asDouble());
      case Json::stringValue: {
        const std::string_view s = jsonString(j);
        if (!isValidUtf8(s)) return fail(path, "string is not valid UTF-8");
        return Variant(std::string(s));
      }
      case Json::arrayValue: {
        Variant::List items;
        items.reserve(j.size());
        for (Json::ArrayIndex i = 0; i < j.size(); ++i) {
          Result<Variant> item = value(j[i], depth + 1, path + "[" + std::to_string(i) + "]");
          if (!item) return item;
          items.push_back(std::move(item).value());
        }
        return Variant(std::move(items));
      }
      case Json::objectValue:
        return object(j, depth, path);
    }
    return fail(path, "unknown JSON type");
  }

 private:
  static Error fail(const std::string& path, const std::string& why) {
    return makeError(Errc::parse_error, path + ": " + why);
  }

  Result<Variant> object(const Json::Value& j, size_t depth, const std::string& path) {
    if (j.size() == 1 && j.isMember(kBase64Key)) {
      const Json::Value& text = j[kBase64Key];
      if (!text.isString()) return fail(path, "\"$base64\" must hold a string");
      std::optional<std::string> bytes = base64Decode(jsonString(text));
      if (!bytes) return fail(path, "\"$base64\" holds invalid base64");
      return Variant(Variant::Bytes(std::move(*bytes)));
    }
    if (j.size() == 1 && j.isMember(kMapKey)) {
      const Json::Value& inner = j[kMapKey];
      if (!inner.isObject()) return fail(path, "\"$map\" must hold an object");
      return members(inner, depth, path);
    }
    return members(j, depth, path);
  }

  Result<Variant> members(const Json::Value& j, size_t depth, const std::string& path) {
    Variant::Map entries;
    for (auto it = j.begin(); it != j.end(); ++it) {
      std::string key = it.name();
      std::string at = path;  // for messages: long keys shortened, so paths stay short
      at += '.';
      at.append(key, 0, 64);
      if (key.size() > 64) at += "...";
      if (key.size() > std::numeric_limits<uint16_t>::max()) {
        return fail(path, "key of " + std::to_string(key.size()) + " bytes exceeds 65535");
      }
      if (!isValidUtf8(key)) return fail(path, "key is not valid UTF-8");
      Result<Variant> item = value(*it, depth + 1, at);
      if (!item) return item;
      entries.emplace(std::move(key), std::move(item).value());
    }
    return Variant(std::move(entries));
  }

  size_t max_depth_;
};

}  // namespace

Json::Value Variant::toJson() const {
  switch (type()) {
    case Type::null:
      return Json::Value(Json::nullValue);
    case Type::boolean:
      return Json::Value(*asBool());
    case Type::int64:
      return Json::Value(static_cast<Json::Int64>(*std::get_if<int64_t>(&v_)));
    case Type::uint64:
      return Json::Value(static_cast<Json::UInt64>(*std::get_if<uint64_t>(&v_)));
    case Type::float64: {
      const double d = *std::get_if<double>(&v_);
      return std::isfinite(d) ? Json::Value(d) : Json::Value(Json::nullValue);
    }
    case Type::string: {
      const std::string& s = *asString();
      return Json::Value(s.data(), s.data() + s.size());
    }
    case Type::bytes: {
      Json::Value out(Json::objectValue);
      out[kBase64Key] = base64Encode(asBytes()->data);
      return out;
    }
    case Type::list: {
      Json::Value out(Json::arrayValue);
      const List& items = *asList();
      if (!items.empty()) out.resize(static_cast<Json::ArrayIndex>(items.size()));
      for (size_t i = 0; i < items.size(); ++i) {
        out[static_cast<Json::ArrayIndex>(i)] = items[i].toJson();
      }
      return out;
    }
    case Type::map: {
      const Map& m = *asMap();
      // A lone "$base64" or "$map" key would read back as bytes or as an escape: escape it.
      if (json_keys::needsMapEscape(m)) {
        Json::Value out(Json::objectValue);
        out[kMapKey] = mapToJson(m);
        return out;
      }
      return mapToJson(m);
    }
  }
  return Json::Value(Json::nullValue);
}

Result<Variant> Variant::fromJson(const Json::Value& json, size_t max_depth) {
  return FromJson(max_depth).value(json, 1, "$");
}

}  // namespace skr::flow
