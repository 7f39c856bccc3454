// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as a binary Variant. Whatever decodes must re-encode to a
// value that decodes equal, stay encodable, and survive the JSON mapping (values holding no
// non-finite float64, which JSON writes as null). The same bytes are also read as the JSON text
// of the protocol's JSON twin commands; whatever parses must encode, round-trip, and read the
// same through jsoncpp and Variant::fromJson().
//
//   cmake --preset fuzz && cmake --build --preset fuzz && build/fuzz/bin/variant_decode_fuzz
#include <skrobot/runtime/flow/variant.h>

#include <json/reader.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <string_view>

namespace {

using skr::flow::Variant;

[[noreturn]] void fail(const char* what, const Variant& v) {
  std::fprintf(stderr, "variant_decode_fuzz: %s\nvalue: %s\n", what,
               skr::flow::variantToJsonText(v).c_str());
  std::abort();
}

bool hasNonFinite(const Variant& v) {
  if (const auto d = v.asDouble(); v.isDouble() && !std::isfinite(*d)) return true;
  if (const Variant::List* l = v.asList()) {
    for (const Variant& item : *l) {
      if (hasNonFinite(item)) return true;
    }
  }
  if (const Variant::Map* m = v.asMap()) {
    for (const auto& [key, item] : *m) {
      if (hasNonFinite(item)) return true;
    }
  }
  return false;
}

// JSON has one integer type: a uint64 that fits int64 comes back as int64.
Variant jsonNormalized(const Variant& v) {
  if (v.isUint64() && v.asInt64()) return *v.asInt64();
  if (const Variant::List* l = v.asList()) {
    Variant::List out;
    for (const Variant& item : *l) out.push_back(jsonNormalized(item));
    return out;
  }
  if (const Variant::Map* m = v.asMap()) {
    Variant::Map out;
    for (const auto& [key, item] : *m) out.emplace(key, jsonNormalized(item));
    return out;
  }
  return v;
}

void checkJsonText(const uint8_t* data, size_t size) {
  skr::Result<Variant> parsed =
      skr::flow::variantFromJsonText(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!parsed) return;
  const Variant& v = parsed.value();
  if (!skr::flow::checkEncodable(v)) fail("a value from JSON is not encodable", v);
  std::string bytes;
  skr::flow::ByteWriter w(bytes);
  skr::flow::encodeVariant(v, w);
  skr::flow::ByteReader in(bytes);
  skr::Result<Variant> back = skr::flow::decodeVariant(in);
  if (!back || !(back.value() == v)) fail("a value from JSON does not round-trip in binary", v);
  skr::Result<Variant> again = skr::flow::variantFromJsonText(skr::flow::variantToJsonText(v));
  if (!again || !(again.value() == v)) fail("a value from JSON does not round-trip in JSON", v);
  // The reference: jsoncpp's reader and Variant::fromJson() must accept it and agree (jsoncpp
  // accepts more: leading zeros, raw control characters; never less).
  Json::CharReaderBuilder builder;
  builder["rejectDupKeys"] = true;
  builder["failIfExtra"] = true;
  builder["stackLimit"] = 1000;
  const std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value root;
  std::string errors;
  const char* text = reinterpret_cast<const char*>(data);
  if (!reader->parse(text, text + size, &root, &errors)) fail("jsoncpp refuses it", v);
  skr::Result<Variant> reference = Variant::fromJson(root);
  if (!reference || !(reference.value() == v)) fail("Variant::fromJson() reads it otherwise", v);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  checkJsonText(data, size);
  skr::flow::ByteReader in(data, size);
  skr::Result<Variant> decoded = skr::flow::decodeVariant(in);
  if (!decoded) {
    if (in.remaining() != size) fail("a failed decode moved the reader", Variant());
    if (decoded.error().message.empty()) fail("a failed decode gave no reason", Variant());
    return 0;
  }
  const Variant& v = decoded.value();
  if (!skr::flow::checkEncodable(v)) fail("a decoded value is not encodable", v);

  std::string bytes;
  skr::flow::ByteWriter w(bytes);
  skr::flow::encodeVariant(v, w);
  if (bytes.size() != skr::flow::encodedSize(v)) fail("encodedSize() disagrees", v);
  if (bytes.size() != size - in.remaining()) fail("the encoding differs in size from the input", v);
  skr::flow::ByteReader again(bytes);
  skr::Result<Variant> back = skr::flow::decodeVariant(again);
  if (!back || !again.empty()) fail("the encoding does not decode", v);
  if (!(back.value() == v)) fail("decode(encode(v)) != v", v);

  if (!hasNonFinite(v)) {
    const std::string text = skr::flow::variantToJsonText(v);
    skr::Result<Variant> parsed = skr::flow::variantFromJsonText(text);
    if (!parsed) fail(("JSON text does not parse: " + parsed.error().message).c_str(), v);
    if (!(parsed.value() == jsonNormalized(v))) fail("JSON text round trip differs", v);
    skr::Result<Variant> from_value = Variant::fromJson(v.toJson());
    if (!from_value || !(from_value.value() == jsonNormalized(v))) {
      fail("toJson/fromJson round trip differs", v);
    }
  }
  return 0;
}
