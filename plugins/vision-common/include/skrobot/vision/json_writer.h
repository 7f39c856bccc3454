// A small JSON writer for the detections the vision modules publish (any thread).
//
//   JsonWriter j;
//   j.beginObject().key("seq").value(seq).key("faces").beginArray();
//   ... j.endArray().endObject();
//   publish(j.str());
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace skr::vision {

class JsonWriter {
 public:
  JsonWriter& beginObject();
  JsonWriter& endObject();
  JsonWriter& beginArray();
  JsonWriter& endArray();
  JsonWriter& key(std::string_view name);
  JsonWriter& value(std::int64_t v);
  JsonWriter& value(std::uint64_t v);
  JsonWriter& value(int v) { return value(static_cast<std::int64_t>(v)); }
  JsonWriter& value(double v);  // finite values with 6 significant digits; NaN/inf as null
  JsonWriter& value(bool v);
  JsonWriter& value(std::string_view text);  // escaped; invalid UTF-8 becomes U+FFFD
  JsonWriter& value(const char* text) { return value(std::string_view(text)); }
  JsonWriter& null();

  [[nodiscard]] const std::string& str() const noexcept { return out_; }

 private:
  void separate();

  std::string out_;
  std::vector<bool> first_;  // per open container: no member written yet
  bool after_key_ = false;
};

// `text` as a JSON string literal, quotes included.
std::string jsonString(std::string_view text);

}  // namespace skr::vision
