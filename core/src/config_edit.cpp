// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/config_edit.h>

#include <skrobot/support/json.hpp>

#include <json/reader.h>

#include <algorithm>
#include <memory>
#include <vector>

namespace skr {

namespace {

struct Edit {
  std::size_t at = 0, length = 0;
  std::string text;
};

// The document with every value's place in the text (jsoncpp's offsets), comments allowed.
Result<Json::Value> parseWithOffsets(std::string_view text) {
  Json::CharReaderBuilder builder;
  builder["collectComments"] = false;
  builder["rejectDupKeys"] = true;
  builder["failIfExtra"] = true;  // as the hub reads it (hub_config.cpp)
  const std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value doc;
  std::string errs;
  try {
    if (!reader->parse(text.data(), text.data() + text.size(), &doc, &errs)) {
      return makeError(Errc::config_error, "the config file no longer parses: " + errs);
    }
  } catch (const std::exception& e) {
    return makeError(Errc::config_error, e.what());
  }
  return doc;
}

std::string member(const std::string& key, const Json::Value& value) {
  return support::writeJson(Json::Value(key)) + ": " + support::writeJson(value);
}

}  // namespace

Result<std::string> editModuleConfig(std::string_view text, std::size_t index,
                                     const Json::Value& values) {
  auto parsed = parseWithOffsets(text);
  if (!parsed) return parsed.error();
  const Json::Value& doc = *parsed;  // const: reading a missing key never makes it
  if (!doc.isObject()) return makeError(Errc::config_error, "the config file is not an object");
  const Json::Value& modules = doc["modules"];
  if (!modules.isArray() || index >= modules.size() ||
      !modules[static_cast<Json::ArrayIndex>(index)].isObject()) {
    return makeError(Errc::config_error,
                     "the config file has no $.modules[" + std::to_string(index) + "] any more");
  }
  const Json::Value& entry = modules[static_cast<Json::ArrayIndex>(index)];
  std::vector<Edit> edits;
  const Json::Value* config = entry.find("config", "config" + 6);
  if (config == nullptr) {
    // After the entry's '{': "config": {...}, before what it holds.
    std::string inner;
    for (const std::string& key : values.getMemberNames()) {
      inner += (inner.empty() ? "" : ", ") + member(key, values[key]);
    }
    edits.push_back({static_cast<std::size_t>(entry.getOffsetStart()) + 1, 0,
                     " \"config\": {" + inner + "}" + (entry.empty() ? " " : ", ")});
  } else if (!config->isObject()) {
    return makeError(Errc::config_error, "$.modules[" + std::to_string(index) +
                                             "].config is not an object in the file");
  } else {
    std::string added;
    for (const std::string& key : values.getMemberNames()) {
      const Json::Value* old = config->find(key.data(), key.data() + key.size());
      if (old != nullptr) {
        const auto start = static_cast<std::size_t>(old->getOffsetStart());
        const auto limit = static_cast<std::size_t>(old->getOffsetLimit());
        edits.push_back({start, limit - start, support::writeJson(values[key])});
      } else {
        added += (added.empty() ? "" : ", ") + member(key, values[key]);
      }
    }
    if (!added.empty()) {
      edits.push_back({static_cast<std::size_t>(config->getOffsetStart()) + 1, 0,
                       added + (config->empty() ? "" : ", ")});
    }
  }
  // From the end, so that each edit's place is still where the parse found it.
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.at > b.at; });
  std::string out(text);
  for (const Edit& e : edits) out.replace(e.at, e.length, e.text);
  return out;
}

}  // namespace skr
