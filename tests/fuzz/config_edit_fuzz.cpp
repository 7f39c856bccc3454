// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as the config file whose module values a save edits in place
// (flowctl module config --save; core/src/config_edit.cpp), which may have changed on disk since
// the hub read it. Editing must never crash; an edited text must parse, with the values set in
// the module's config and its other keys as they were.
//
//   cmake --preset fuzz && cmake --build --preset fuzz && build/fuzz/bin/config_edit_fuzz
#include <skrobot/hub/config_edit.h>

#include <json/reader.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

namespace {

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "config_edit_fuzz: %s\n", what.c_str());
  std::abort();
}

bool parse(const std::string& text, Json::Value& doc) {
  Json::CharReaderBuilder builder;
  builder["collectComments"] = false;
  builder["rejectDupKeys"] = true;
  builder["failIfExtra"] = true;
  const std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  std::string errs;
  try {
    return reader->parse(text.data(), text.data() + text.size(), &doc, &errs);
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const size_t index = data[0] % 4;  // which entry of "modules"
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  Json::Value values;
  values["greeting"] = "hello \"world\"";
  values["period_ms"] = 20;
  auto edited = skr::editModuleConfig(text, index, values);
  if (!edited) return 0;
  Json::Value before;
  Json::Value after;
  if (!parse(text, before)) fail("an edit of a text that does not parse");
  if (!parse(*edited, after)) fail("the edited text does not parse:\n" + *edited);
  const auto i = static_cast<Json::ArrayIndex>(index);
  const Json::Value& edited_doc = after;  // const: reading never adds
  const Json::Value& original = before;
  if (!edited_doc.isObject()) fail("the edited text is not an object:\n" + *edited);
  const Json::Value& config = edited_doc["modules"][i]["config"];
  for (const std::string& key : values.getMemberNames()) {
    if (config[key] != values[key]) fail("the value of " + key + " was not set:\n" + *edited);
  }
  const Json::Value& old = original["modules"][i]["config"];
  for (const std::string& key : old.getMemberNames()) {
    if (!values.isMember(key) && config[key] != old[key]) fail(key + " changed:\n" + *edited);
  }
  return 0;
}
