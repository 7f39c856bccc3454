// SPDX-License-Identifier: Apache-2.0
// Variant: construction, conversions, the binary wire encoding (byte-exact and against hostile
// input) and the JSON mapping.
#include <skrobot/runtime/flow/variant.h>

#include <gtest/gtest.h>
#include <json/reader.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

// The largest single allocation while `g_track` is set: decoding hostile lengths must not
// allocate what they announce.
namespace {
std::atomic<bool> g_track{false};
std::atomic<size_t> g_largest{0};
}  // namespace

void* operator new(size_t n) {
  if (g_track.load(std::memory_order_relaxed)) {
    size_t prev = g_largest.load(std::memory_order_relaxed);
    while (n > prev && !g_largest.compare_exchange_weak(prev, n)) {
    }
  }
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, size_t) noexcept {
  std::free(p);
}

namespace skr::flow {
namespace {

using Type = Variant::Type;
using List = Variant::List;
using Map = Variant::Map;
using Bytes = Variant::Bytes;

#define EXPECT_HAS(haystack, needle) \
  EXPECT_NE((haystack).find(needle), std::string::npos) << (haystack)

std::string enc(const Variant& v) {
  std::string out;
  ByteWriter w(out);
  encodeVariant(v, w);
  return out;
}

Result<Variant> dec(std::string_view bytes, const DecodeLimits& limits = {}) {
  ByteReader r(bytes);
  return decodeVariant(r, limits);
}

// "02 01 ff" -> bytes.
std::string unhex(std::string_view text) {
  std::string out;
  for (size_t i = 0; i < text.size();) {
    if (text[i] == ' ') {
      ++i;
      continue;
    }
    out += static_cast<char>(std::stoi(std::string(text.substr(i, 2)), nullptr, 16));
    i += 2;
  }
  return out;
}

std::string hex(std::string_view bytes) {
  std::string out;
  char buf[4];
  for (const char c : bytes) {
    std::snprintf(buf, sizeof buf, "%02x", static_cast<unsigned char>(c));
    if (!out.empty()) out += ' ';
    out += buf;
  }
  return out;
}

// The error message of bytes that must not decode.
std::string decodeError(std::string_view bytes, const DecodeLimits& limits = {}) {
  Result<Variant> r = dec(bytes, limits);
  if (r.ok()) {
    ADD_FAILURE() << "decoded " << hex(bytes);
    return {};
  }
  EXPECT_EQ(r.error().code, Errc::protocol_error);
  return r.error().message;
}

std::string allByteValues() {
  std::string s;
  for (int i = 0; i < 256; ++i) s += static_cast<char>(i);
  return s;
}

// One of everything, nested.
Variant sampleValue() {
  Map inner{{"empty list", List{}}, {"empty map", Map{}}, {"", "empty key"}};
  return Map{
      {"null", nullptr},
      {"t", true},
      {"f", false},
      {"i", int64_t{-42}},
      {"imin", std::numeric_limits<int64_t>::min()},
      {"imax", std::numeric_limits<int64_t>::max()},
      {"umax", std::numeric_limits<uint64_t>::max()},
      {"d", 3.25},
      {"tiny", std::numeric_limits<double>::denorm_min()},
      {"s", "h\xC3\xA9llo \xE2\x82\xAC \xF0\x9F\xA4\x96"},  // é, €, robot face
      {"nul", std::string("a\0b", 3)},
      {"empty", ""},
      {"bytes", Bytes(allByteValues())},
      {"no bytes", Bytes()},
      {"list", List{1, "two", List{3.5, List{}}, inner}},
      {"map", inner},
  };
}

// --- construction and access ----------------------------------------------------------------

TEST(VariantTest, ConstructorsPickTheType) {
  EXPECT_EQ(Variant().type(), Type::null);
  EXPECT_EQ(Variant(nullptr).type(), Type::null);
  EXPECT_EQ(Variant(true).type(), Type::boolean);
  EXPECT_EQ(Variant(1).type(), Type::int64);
  EXPECT_EQ(Variant(1L).type(), Type::int64);
  EXPECT_EQ(Variant(int64_t{1}).type(), Type::int64);
  EXPECT_EQ(Variant(int8_t{1}).type(), Type::int64);
  EXPECT_EQ(Variant(short{1}).type(), Type::int64);
  EXPECT_EQ(Variant(1u).type(), Type::uint64);
  EXPECT_EQ(Variant(size_t{1}).type(), Type::uint64);
  EXPECT_EQ(Variant(uint8_t{1}).type(), Type::uint64);
  EXPECT_EQ(Variant(uint64_t{1}).type(), Type::uint64);
  EXPECT_EQ(Variant(1.5f).type(), Type::float64);
  EXPECT_EQ(Variant(1.5).type(), Type::float64);
  EXPECT_EQ(Variant("x").type(), Type::string);
  char buf[] = "x";
  EXPECT_EQ(Variant(static_cast<char*>(buf)).type(), Type::string);
  EXPECT_EQ(Variant(std::string("x")).type(), Type::string);
  EXPECT_EQ(Variant(std::string_view("x")).type(), Type::string);
  EXPECT_EQ(Variant(Bytes("x")).type(), Type::bytes);
  EXPECT_EQ(Variant(Bytes(std::vector<uint8_t>{1, 2})).asBytes()->data, std::string("\x01\x02"));
  EXPECT_EQ(Variant(List{}).type(), Type::list);
  EXPECT_EQ(Variant(Map{}).type(), Type::map);
  // Characters and non-char pointers would silently become numbers or bools.
  static_assert(!std::is_constructible_v<Variant, char>);
  static_assert(!std::is_constructible_v<Variant, int*>);
  static_assert(!std::is_constructible_v<Variant, const void*>);
  static_assert(std::is_nothrow_move_constructible_v<Variant>);
}

TEST(VariantTest, TypeNames) {
  EXPECT_EQ(Variant().typeName(), "null");
  EXPECT_EQ(Variant(false).typeName(), "bool");
  EXPECT_EQ(Variant(1).typeName(), "int64");
  EXPECT_EQ(Variant(1u).typeName(), "uint64");
  EXPECT_EQ(Variant(1.0).typeName(), "float64");
  EXPECT_EQ(Variant("").typeName(), "string");
  EXPECT_EQ(Variant(Bytes()).typeName(), "bytes");
  EXPECT_EQ(Variant(List{}).typeName(), "list");
  EXPECT_EQ(Variant(Map{}).typeName(), "map");
}

TEST(VariantTest, NumericConversionsOnlyWhenExact) {
  EXPECT_EQ(Variant(uint64_t{5}).asInt64(), 5);
  EXPECT_EQ(Variant(std::numeric_limits<uint64_t>::max()).asInt64(), std::nullopt);
  EXPECT_EQ(Variant(3.0).asInt64(), 3);
  EXPECT_EQ(Variant(3.5).asInt64(), std::nullopt);
  EXPECT_EQ(Variant(-9223372036854775808.0).asInt64(), std::numeric_limits<int64_t>::min());
  EXPECT_EQ(Variant(9223372036854775808.0).asInt64(), std::nullopt);
  EXPECT_EQ(Variant(std::nan("")).asInt64(), std::nullopt);
  EXPECT_EQ(Variant(-1).asUint64(), std::nullopt);
  EXPECT_EQ(Variant(7).asUint64(), 7u);
  EXPECT_EQ(Variant(1e19).asUint64(), uint64_t{10000000000000000000u});
  EXPECT_EQ(Variant(18446744073709551616.0).asUint64(), std::nullopt);
  EXPECT_EQ(Variant(-2).asDouble(), -2.0);
  EXPECT_EQ(Variant(2u).asDouble(), 2.0);
  EXPECT_EQ(Variant("1").asInt64(), std::nullopt);
  EXPECT_EQ(Variant(true).asInt64(), std::nullopt);
  EXPECT_EQ(Variant(1).asBool(), std::nullopt);
  EXPECT_EQ(Variant(true).asBool(), true);
  EXPECT_TRUE(Variant(1).isNumber());
  EXPECT_FALSE(Variant("1").isNumber());
}

TEST(VariantTest, PointerAccessorsAndFind) {
  Variant v = Map{{"a", 1}, {"b", List{"x"}}};
  EXPECT_EQ(v.asString(), nullptr);
  EXPECT_EQ(v.asList(), nullptr);
  ASSERT_NE(v.asMap(), nullptr);
  ASSERT_NE(v.find("b"), nullptr);
  EXPECT_EQ(*v.find("b")->asList()->at(0).asString(), "x");
  EXPECT_EQ(v.find("zz"), nullptr);
  EXPECT_EQ(Variant(1).find("a"), nullptr);
  (*v.asMap())["c"] = 3;  // built in place
  EXPECT_EQ(v.find("c")->asInt64(), 3);
}

TEST(VariantTest, CopiesAreDeepMovesLeaveNull) {
  Variant a = List{1, Map{{"k", "v"}}};
  Variant b = a;
  (*b.asList())[0] = 2;
  EXPECT_EQ(a.asList()->at(0).asInt64(), 1);
  Variant c = std::move(a);
  EXPECT_TRUE(a.isNull());  // NOLINT(bugprone-use-after-move): the contract
  EXPECT_EQ(c.asList()->size(), 2u);
  b = std::move(c);
  EXPECT_TRUE(c.isNull());  // NOLINT(bugprone-use-after-move)
  EXPECT_EQ(b.asList()->at(0).asInt64(), 1);
}

TEST(VariantTest, AssignFromOwnChild) {
  Variant v = List{1, List{2}};
  v = (*v.asList())[0];  // the child dies with the list it is copied from
  EXPECT_EQ(v, Variant(1));
  v = List{List{2}, 3};
  v = std::move((*v.asList())[0]);
  EXPECT_EQ(v, Variant(List{2}));
  v = Map{{"k", "text"}};
  v = *v.find("k");
  EXPECT_EQ(v, Variant("text"));
  Variant& self = v;
  v = self;
  v = std::move(self);
  EXPECT_EQ(v, Variant("text"));
}

TEST(VariantTest, Equality) {
  EXPECT_EQ(Variant(1), Variant(int64_t{1}));
  EXPECT_NE(Variant(1), Variant(1u));  // types differ
  EXPECT_NE(Variant(1), Variant(1.0));
  EXPECT_EQ(Variant(std::nan("")), Variant(std::nan("")));  // a value equals its copy
  EXPECT_EQ(Variant(0.0), Variant(-0.0));
  EXPECT_NE(Variant("a"), Variant(Bytes("a")));
  EXPECT_EQ(sampleValue(), sampleValue());
  Variant changed = sampleValue();
  (*changed.asMap())["list"].asList()->push_back(nullptr);
  EXPECT_NE(changed, sampleValue());
}

// --- binary encoding -------------------------------------------------------------------------

TEST(VariantBinaryTest, ByteExactEncodings) {
  // The examples of docs/flow-protocol.md.
  EXPECT_EQ(hex(enc(Variant())), "00");
  EXPECT_EQ(hex(enc(Variant(false))), "01 00");
  EXPECT_EQ(hex(enc(Variant(true))), "01 01");
  EXPECT_EQ(hex(enc(Variant(1))), "02 01 00 00 00 00 00 00 00");
  EXPECT_EQ(hex(enc(Variant(-2))), "02 fe ff ff ff ff ff ff ff");
  EXPECT_EQ(hex(enc(Variant(uint64_t{0x0102030405060708}))), "03 08 07 06 05 04 03 02 01");
  EXPECT_EQ(hex(enc(Variant(1.0))), "04 00 00 00 00 00 00 f0 3f");
  EXPECT_EQ(hex(enc(Variant("hi"))), "05 02 00 00 00 68 69");
  EXPECT_EQ(hex(enc(Variant(Bytes("\x00\xff", 2)))), "06 02 00 00 00 00 ff");
  EXPECT_EQ(hex(enc(Variant(List{nullptr, true}))), "07 02 00 00 00 00 01 01");
  EXPECT_EQ(hex(enc(Variant(Map{{"b", 1u}, {"a", false}}))),
            "08 02 00 00 00 01 00 61 01 00 01 00 62 03 01 00 00 00 00 00 00 00");
  EXPECT_EQ(hex(enc(Variant(List{}))), "07 00 00 00 00");
  EXPECT_EQ(hex(enc(Variant(Map{}))), "08 00 00 00 00");
}

TEST(VariantBinaryTest, RoundTripsEveryType) {
  const Variant values[] = {
      Variant(),
      true,
      false,
      0,
      std::numeric_limits<int64_t>::min(),
      std::numeric_limits<int64_t>::max(),
      std::numeric_limits<uint64_t>::max(),
      -0.0,
      std::numeric_limits<double>::infinity(),
      -std::numeric_limits<double>::infinity(),
      std::numeric_limits<double>::max(),
      std::numeric_limits<double>::denorm_min(),
      "",
      "\xF4\x8F\xBF\xBF",  // U+10FFFF
      Bytes(allByteValues()),
      List{},
      Map{},
      sampleValue(),
      List{List{List{Map{{"deep", List{}}}}}},
  };
  for (const Variant& v : values) {
    const std::string bytes = enc(v);
    EXPECT_EQ(bytes.size(), encodedSize(v));
    ByteReader r(bytes);
    Result<Variant> back = decodeVariant(r);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back.value(), v) << variantToJsonText(v);
    EXPECT_TRUE(r.empty());
  }
}

TEST(VariantBinaryTest, NanKeepsItsBits) {
  const double nan = std::nan("0x123");
  Result<Variant> back = dec(enc(Variant(nan)));
  ASSERT_TRUE(back.ok());
  const double d = *back->asDouble();
  EXPECT_TRUE(std::isnan(d));
  EXPECT_EQ(std::memcmp(&d, &nan, sizeof d), 0);
}

TEST(VariantBinaryTest, ReadsOneValueAndLeavesTheRest) {
  std::string bytes = enc(Variant(7)) + "\xAA\xBB";
  ByteReader r(bytes);
  Result<Variant> v = decodeVariant(r);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(r.remaining(), 2u);

  ByteReader bad(std::string_view("\x05\x09\x00\x00\x00hi", 7));
  EXPECT_FALSE(decodeVariant(bad).ok());
  EXPECT_EQ(bad.remaining(), 7u);  // untouched on error
}

TEST(VariantBinaryTest, EveryTruncationFailsCleanly) {
  const std::string bytes = enc(sampleValue());
  for (size_t n = 0; n < bytes.size(); ++n) {
    ByteReader r(bytes.data(), n);
    Result<Variant> v = decodeVariant(r);
    ASSERT_FALSE(v.ok()) << "prefix of " << n << " bytes decoded";
    EXPECT_EQ(v.error().code, Errc::protocol_error);
    EXPECT_EQ(r.remaining(), n);
  }
  EXPECT_HAS(decodeError(""), "truncated: tag needs 1 byte, 0 bytes left (at byte 0)");
  EXPECT_HAS(decodeError(unhex("02 01 00 00")), "truncated: int64 needs 8 bytes, 3 bytes left");
  EXPECT_HAS(decodeError(unhex("01")), "truncated: bool");
}

TEST(VariantBinaryTest, HugeLengthsFailWithoutAllocating) {
  const std::string cases[] = {
      unhex("05 ff ff ff ff 61 62 63"),           // string
      unhex("06 ff ff ff ff 61 62 63"),           // bytes
      unhex("07 ff ff ff ff 00 00 00"),           // list
      unhex("08 ff ff ff ff 01 00 61"),           // map
      unhex("07 03 00 00 00 07 ff ff ff ff 00"),  // nested list
  };
  for (const std::string& c : cases) {
    g_largest = 0;
    g_track = true;
    Result<Variant> r = dec(c);
    g_track = false;
    EXPECT_FALSE(r.ok()) << hex(c);
    EXPECT_LT(g_largest.load(), 4096u) << hex(c);  // the error message, nothing announced
  }
  EXPECT_HAS(decodeError(unhex("05 00 09 3d 00 61 62 63 64 65 66 67 68 69 6a 6b 6c")),
             "string length 4000000 exceeds the 12 bytes left (at byte 1)");
  EXPECT_HAS(decodeError(unhex("07 ff ff ff ff 00 00 00")),
             "list count 4294967295 exceeds the 3 bytes left");
  EXPECT_HAS(decodeError(unhex("08 02 00 00 00 01 00 61 00")),
             "map count 2 exceeds the 4 bytes left (each element takes at least 3 bytes)");
  EXPECT_HAS(decodeError(unhex("06 05 00 00 00 61")), "bytes length 5 exceeds the 1 bytes left");
}

TEST(VariantBinaryTest, ListOfManyNullsDecodes) {
  // A count equal to the bytes left is possible: one byte per null.
  std::string bytes = unhex("07 00 00 01 00") + std::string(0x10000, '\0');
  Result<Variant> v = dec(bytes);
  ASSERT_TRUE(v.ok()) << v.error().message;
  EXPECT_EQ(v->asList()->size(), 0x10000u);
}

TEST(VariantBinaryTest, DepthLimit) {
  const auto nested = [](size_t levels) {  // `levels` lists, the innermost empty
    Variant v = List{};
    for (size_t i = 1; i < levels; ++i) v = List{std::move(v)};
    return v;
  };
  EXPECT_TRUE(dec(enc(nested(32))).ok());
  EXPECT_HAS(decodeError(enc(nested(33))), "variant at depth 33 exceeds the limit of 32");
  EXPECT_HAS(decodeError(enc(List{List{1}}), {.max_depth = 2}),
             "variant at depth 3 exceeds the limit of 2");
  // A long run of list headers never recurses past the limit, whatever the input length.
  std::string deep;
  for (int i = 0; i < 100000; ++i) deep += unhex("07 01 00 00 00");
  EXPECT_HAS(decodeError(deep), "variant at depth 33 exceeds the limit of 32");
  EXPECT_TRUE(checkEncodable(nested(32)).ok());
  Result<void> too_deep = checkEncodable(nested(33));
  ASSERT_FALSE(too_deep.ok());
  EXPECT_EQ(too_deep.error().code, Errc::limit_exceeded);
}

TEST(VariantBinaryTest, SizeLimit) {
  const std::string bytes = enc(Variant(std::string(100, 'x')));
  EXPECT_TRUE(dec(bytes, {.max_bytes = bytes.size()}).ok());
  EXPECT_HAS(decodeError(bytes, {.max_bytes = 50}),
             "string length 100 exceeds the 45 bytes left under the value size limit of 50");
  Result<void> r = checkEncodable(Variant(std::string(100, 'x')), {.max_bytes = 50});
  ASSERT_FALSE(r.ok());
  EXPECT_HAS(r.error().message, "encoded size 105 exceeds the limit of 50");
}

TEST(VariantBinaryTest, BadTagsAndBools) {
  EXPECT_HAS(decodeError(unhex("2a")), "unknown variant tag 0x2a (at byte 0)");
  EXPECT_HAS(decodeError(unhex("09")), "unknown variant tag 0x09");
  EXPECT_HAS(decodeError(unhex("ff")), "unknown variant tag 0xff");
  EXPECT_HAS(decodeError(unhex("07 02 00 00 00 00 63")), "unknown variant tag 0x63 (at byte 6)");
  EXPECT_HAS(decodeError(unhex("01 07")), "bad bool byte 0x07 (at byte 1)");
  EXPECT_HAS(decodeError(unhex("01 02")), "bad bool byte 0x02");
}

TEST(VariantBinaryTest, InvalidUtf8Refused) {
  const std::string bad[] = {
      "\xC0\x80",          // overlong NUL
      "\xE0\x80\xAF",      // overlong '/'
      "\xED\xA0\x80",      // surrogate U+D800
      "\xF4\x90\x80\x80",  // above U+10FFFF
      "\xF5\x80\x80\x80",  // never valid
      "\x80",              // lone continuation
      "\xE2\x82",          // truncated sequence
      "a\xFF",
  };
  for (const std::string& s : bad) {
    EXPECT_FALSE(isValidUtf8(s)) << hex(s);
    std::string bytes =
        unhex("05") + std::string(1, static_cast<char>(s.size())) + std::string("\0\0\0", 3) + s;
    EXPECT_HAS(decodeError(bytes), "string is not valid UTF-8");
    std::string key = unhex("08 01 00 00 00") + std::string(1, static_cast<char>(s.size())) +
                      std::string(1, '\0') + s + unhex("00");
    EXPECT_HAS(decodeError(key), "map key is not valid UTF-8 (at byte 7)");
  }
  EXPECT_TRUE(isValidUtf8(std::string("\0\x7F\xC2\x80\xEF\xBF\xBF\xF0\x90\x80\x80", 11)));
  // Bytes are not text: anything goes.
  EXPECT_TRUE(dec(enc(Variant(Bytes("\xFF\xFE")))).ok());
  Result<void> r = checkEncodable(List{1, Map{{"k", "\xFF"}}});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "$[1].\"k\": string is not valid UTF-8");
}

TEST(VariantBinaryTest, DuplicateKeyRefused) {
  EXPECT_HAS(decodeError(unhex("08 02 00 00 00 01 00 78 00 01 00 78 01 01")),
             "duplicate map key \"x\" (at byte 9)");
  // Keys in any order decode; the encoder writes them sorted.
  Result<Variant> v = dec(unhex("08 02 00 00 00 01 00 62 00 01 00 61 00"));
  ASSERT_TRUE(v.ok()) << v.error().message;
  EXPECT_EQ(hex(enc(v.value())), "08 02 00 00 00 01 00 61 00 01 00 62 00");
}

TEST(VariantBinaryTest, LongKeysAreNotEncodable) {
  Result<void> r = checkEncodable(Map{{std::string(65536, 'k'), 1}});
  ASSERT_FALSE(r.ok());
  EXPECT_HAS(r.error().message, "key of 65536 bytes exceeds 65535");
  EXPECT_TRUE(checkEncodable(Map{{std::string(65535, 'k'), 1}}).ok());
  EXPECT_TRUE(checkEncodable(sampleValue()).ok());
}

// --- JSON ------------------------------------------------------------------------------------

Variant fromText(std::string_view text) {
  Result<Variant> r = variantFromJsonText(text);
  EXPECT_TRUE(r.ok()) << text << ": " << r.error().message;
  return r.ok() ? r.value() : Variant();
}

std::string jsonError(std::string_view text, const DecodeLimits& limits = {}) {
  Result<Variant> r = variantFromJsonText(text, limits);
  if (r.ok()) {
    ADD_FAILURE() << "parsed " << text;
    return {};
  }
  EXPECT_EQ(r.error().code, Errc::parse_error);
  return r.error().message;
}

TEST(VariantJsonTest, CompactText) {
  EXPECT_EQ(variantToJsonText(Map{{"a", 1}, {"b", List{true, nullptr}}, {"c", "x"}}),
            R"({"a":1,"b":[true,null],"c":"x"})");
  EXPECT_EQ(variantToJsonText(Bytes("\x00\x01\x02", 3)), R"({"$base64":"AAEC"})");
  EXPECT_EQ(variantToJsonText(std::numeric_limits<uint64_t>::max()), "18446744073709551615");
  EXPECT_EQ(variantToJsonText(std::numeric_limits<int64_t>::min()), "-9223372036854775808");
  EXPECT_EQ(variantToJsonText(2.5), "2.5");
  EXPECT_EQ(variantToJsonText(3.0), "3.0");                  // stays a real
  EXPECT_EQ(variantToJsonText("\xC3\xA9"), "\"\xC3\xA9\"");  // UTF-8 unescaped
}

TEST(VariantJsonTest, NonFiniteDoublesBecomeNull) {
  EXPECT_EQ(variantToJsonText(std::nan("")), "null");
  EXPECT_EQ(variantToJsonText(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(variantToJsonText(-std::numeric_limits<double>::infinity()), "null");
  EXPECT_TRUE(Variant(std::nan("")).toJson().isNull());
}

TEST(VariantJsonTest, RoundTrips) {
  const Variant values[] = {
      Variant(),
      true,
      std::numeric_limits<int64_t>::min(),
      std::numeric_limits<int64_t>::max(),
      std::numeric_limits<uint64_t>::max(),
      0.1,
      -0.0,
      1e300,
      std::numeric_limits<double>::max(),
      std::numeric_limits<double>::min(),
      3.0,
      "",
      Bytes(),
      Bytes(allByteValues()),
      List{},
      Map{},
      sampleValue(),
      Map{{"$base64", "AAAA"}},  // escaped as {"$map": ...}
      Map{{"$map", 1}},
      Map{{"$base64", "x"}, {"y", 1}},  // two keys: no escape needed
  };
  for (const Variant& v : values) {
    Result<Variant> via_value = Variant::fromJson(v.toJson());
    ASSERT_TRUE(via_value.ok()) << via_value.error().message;
    EXPECT_EQ(via_value.value(), v) << variantToJsonText(v);
    EXPECT_EQ(fromText(variantToJsonText(v)), v) << variantToJsonText(v);
  }
  EXPECT_EQ(variantToJsonText(Map{{"$base64", "AAAA"}}), R"({"$map":{"$base64":"AAAA"}})");
}

TEST(VariantJsonTest, IntegerTypes) {
  EXPECT_EQ(fromText("5"), Variant(5));
  EXPECT_EQ(fromText("-5"), Variant(-5));
  EXPECT_EQ(fromText("9223372036854775807"), Variant(std::numeric_limits<int64_t>::max()));
  EXPECT_EQ(fromText("9223372036854775808"), Variant(uint64_t{9223372036854775808u}));
  EXPECT_EQ(fromText("5.0"), Variant(5.0));
  EXPECT_EQ(fromText("1e2"), Variant(100.0));
  // JSON has one integer type: a small uint64 comes back as int64, equal in value.
  Result<Variant> back = Variant::fromJson(Variant(5u).toJson());
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back.value(), Variant(5));
  EXPECT_EQ(back->asUint64(), 5u);
}

TEST(VariantJsonTest, SubnormalDoubles) {
  const double tiny = std::numeric_limits<double>::denorm_min();
  EXPECT_EQ(variantToJsonText(tiny), "5e-324");
  EXPECT_EQ(fromText(variantToJsonText(tiny)), Variant(tiny));
  EXPECT_HAS(jsonError("1e400"), "'1e400' is not a number");  // out of range is refused
}

TEST(VariantJsonTest, BytesAndEscapes) {
  EXPECT_EQ(fromText(R"({"$base64":""})"), Variant(Bytes()));
  EXPECT_EQ(fromText(R"({"$base64":"Zm9vYg=="})"), Variant(Bytes("foob")));
  EXPECT_EQ(fromText(R"({"$map":{"$base64":5}})"), Variant(Map{{"$base64", 5}}));
  EXPECT_EQ(fromText(R"({"$map":{}})"), Variant(Map{}));
  EXPECT_EQ(fromText(R"({"$base64":"AA==","other":1})"),
            Variant(Map{{"$base64", "AA=="}, {"other", 1}}));
  EXPECT_HAS(jsonError(R"({"$base64":"A"})"), "$: \"$base64\" holds invalid base64");
  EXPECT_HAS(jsonError(R"({"$base64":"AB=="})"), "invalid base64");  // non-zero unused bits
  EXPECT_HAS(jsonError(R"({"$base64":"A===" })"), "invalid base64");
  EXPECT_HAS(jsonError(R"({"$base64":"Zm9v YmFy"})"), "invalid base64");
  EXPECT_HAS(jsonError(R"([{"$base64":5}])"), "$[0]: \"$base64\" must hold a string");
  EXPECT_HAS(jsonError(R"({"$map":[1]})"), "\"$map\" must hold an object");
}

TEST(VariantJsonTest, Base64Vectors) {
  // RFC 4648 section 10.
  const std::pair<const char*, const char*> vectors[] = {
      {"", ""},
      {"f", "Zg=="},
      {"fo", "Zm8="},
      {"foo", "Zm9v"},
      {"foob", "Zm9vYg=="},
      {"fooba", "Zm9vYmE="},
      {"foobar", "Zm9vYmFy"},
  };
  for (const auto& [plain, text] : vectors) {
    EXPECT_EQ(base64Encode(plain), text);
    EXPECT_EQ(base64Decode(text), std::string(plain));
  }
  EXPECT_EQ(base64Decode(base64Encode(allByteValues())), allByteValues());
  EXPECT_EQ(base64Encode("\xFB\xFF"), "+/8=");
  EXPECT_EQ(base64Decode("-_8="), std::nullopt);  // the URL alphabet is not standard base64
  EXPECT_EQ(base64Decode("Zg="), std::nullopt);
  EXPECT_EQ(base64Decode("Zg==Zg=="), std::nullopt);
  EXPECT_EQ(base64Decode("Zh=="), std::nullopt);  // unused bits must be zero
  EXPECT_EQ(base64Decode("Zm9="), std::nullopt);
  EXPECT_EQ(base64Decode("===="), std::nullopt);
  EXPECT_EQ(base64Decode("Zm=v"), std::nullopt);
  EXPECT_EQ(base64Encode(std::string("\xff\xfe\x00", 3)), "//4A");
}

TEST(VariantJsonTest, ParseErrors) {
  EXPECT_FALSE(jsonError("").empty());
  EXPECT_FALSE(jsonError("{").empty());
  EXPECT_FALSE(jsonError("[1,]").empty());
  EXPECT_FALSE(jsonError("1 2").empty());
  EXPECT_FALSE(jsonError("NaN").empty());
  EXPECT_FALSE(jsonError("// c\n1").empty());
  EXPECT_FALSE(jsonError("'x'").empty());
  EXPECT_EQ(jsonError(R"({"a":1,"a":2})"), "Line 1, Column 8: Duplicate key: 'a'");
  EXPECT_HAS(jsonError("\"\xFF\""), "$: string is not valid UTF-8");
  EXPECT_HAS(jsonError("{\"\xFF\":1}"), "key is not valid UTF-8");
  EXPECT_HAS(jsonError(R"("\udc00")"), "Lone surrogate");
  EXPECT_HAS(jsonError(R"("\ud800")"), "Lone surrogate");
  EXPECT_HAS(jsonError(R"("\ud800\u0041")"), "Lone surrogate");
  EXPECT_HAS(jsonError("[1]", {.max_bytes = 2}), "exceeds the limit of 2");
}

TEST(VariantJsonTest, StrictGrammar) {
  // RFC 8259 only: what jsoncpp let through is refused with the place it stopped.
  EXPECT_EQ(jsonError("01"), "Line 1, Column 1: '01' is not a number.");
  EXPECT_HAS(jsonError("-"), "'-' is not a number");
  EXPECT_HAS(jsonError("1."), "'1.' is not a number");
  EXPECT_HAS(jsonError("+1"), "Syntax error");
  EXPECT_HAS(jsonError(".5"), "Syntax error");
  EXPECT_EQ(jsonError("[1,\n \"a\tb\"]"),
            "Line 2, Column 4: Control character in a string: escape it");
  EXPECT_HAS(jsonError(R"("\x")"), "Bad escape sequence");
  EXPECT_HAS(jsonError(R"("\u12")"), "Bad unicode escape");
  EXPECT_HAS(jsonError("\"abc"), "Missing '\"'");
  EXPECT_HAS(jsonError(R"({"a":1 "b":2})"), "Missing ',' or '}'");
  EXPECT_HAS(jsonError("tru"), "Syntax error");
  EXPECT_EQ(fromText(" \t\r\n[ 1 , -0 , 1E+2 , 2.5e-3 ] \n"), Variant(List{1, 0, 100.0, 0.0025}));
  EXPECT_EQ(fromText(R"("\"\\\/\b\f\n\r\t\u00e9")"), Variant("\"\\/\b\f\n\r\t\xC3\xA9"));
  EXPECT_EQ(fromText("18446744073709551616"), Variant(18446744073709551616.0));  // beyond uint64
  EXPECT_EQ(fromText("-9223372036854775809"), Variant(-9223372036854775809.0));
}

TEST(VariantJsonTest, ShortestDoubles) {
  EXPECT_EQ(variantToJsonText(0.1), "0.1");
  EXPECT_EQ(variantToJsonText(3.0), "3.0");  // reads back as float64, not int64
  EXPECT_EQ(variantToJsonText(-0.0), "-0.0");
  EXPECT_EQ(variantToJsonText(1e20), "1e+20");
  EXPECT_EQ(variantToJsonText(std::numeric_limits<double>::quiet_NaN()), "null");
  for (double d : {0.1, 1.0 / 3, 1e-7, 123456789.125, 1.5e16, 1e300, -2.2250738585072014e-308}) {
    EXPECT_EQ(fromText(variantToJsonText(d)), Variant(d)) << variantToJsonText(d);
  }
}

TEST(VariantJsonTest, EscapesInsideEscapes) {
  // The object inside a "$map" escape is a map as is, even when its own single key is an escape.
  EXPECT_EQ(fromText(R"({"$map":{"$map":{}}})"), Variant(Map{{"$map", Map{}}}));
  EXPECT_EQ(fromText(R"({"$map":{"$map":{"$base64":"AA=="}}})"),
            Variant(Map{{"$map", Bytes(std::string(1, '\0'))}}));
  EXPECT_EQ(fromText(R"({"$map":{"$base64":"AA=="}})"), Variant(Map{{"$base64", "AA=="}}));
  EXPECT_EQ(fromText(R"([{"$map":{"$map":{"$map":{"a":1}}}}])"),
            Variant(List{Map{{"$map", Map{{"a", 1}}}}}));
  EXPECT_EQ(fromText(R"({"$base64":{"$base64":"AA=="},"x":[{"$base64":""}]})"),
            Variant(Map{{"$base64", Bytes(std::string(1, '\0'))}, {"x", List{Bytes()}}}));
  EXPECT_HAS(jsonError(R"({"a":{"$map":[]}})"), "$.a: \"$map\" must hold an object");
  EXPECT_HAS(jsonError(R"({"a":[{"b":{"$base64":1}}]})"), "$.a[0].b: \"$base64\" must hold");
}

// The text reader gives what jsoncpp's reader and Variant::fromJson() give, wherever both accept.
TEST(VariantJsonTest, AgreesWithTheJsonValueMapping) {
  const char* texts[] = {
      R"({"pose":[1.5,-2,3e2],"name":"r\u00e9b","ok":true,"none":null})",
      R"({"$map":{"$base64":5}})",
      R"({"$map":{"$map":{"$map":{}}}})",
      R"({"$base64":"Zm9vYmFy"})",
      R"([[[[{"$base64":""}]]]])",
      R"({"a":{"b":{"c":{"$map":{"d":[9223372036854775807,9223372036854775808]}}}}})",
      R"("\ud83e\udd16 \u0000")",
      R"([0.1,1e-300,-0.0,18446744073709551615])",
  };
  for (const char* text : texts) {
    Json::Value root;
    std::string errors;
    const std::unique_ptr<Json::CharReader> reader(Json::CharReaderBuilder().newCharReader());
    ASSERT_TRUE(reader->parse(text, text + std::strlen(text), &root, &errors)) << text;
    Result<Variant> via_value = Variant::fromJson(root);
    ASSERT_TRUE(via_value.ok()) << text << ": " << via_value.error().message;
    EXPECT_EQ(fromText(text), via_value.value()) << text;
  }
}

TEST(VariantJsonTest, ScalarsAtTheRoot) {
  EXPECT_EQ(fromText("null"), Variant());
  EXPECT_EQ(fromText("true"), Variant(true));
  EXPECT_EQ(fromText(" \"x\" "), Variant("x"));
  EXPECT_EQ(fromText(R"("a\u0000b")"), Variant(std::string("a\0b", 3)));
  EXPECT_EQ(fromText(R"("\ud83e\udd16")"), Variant("\xF0\x9F\xA4\x96"));
}

TEST(VariantJsonTest, DepthLimit) {
  std::string ok_text;
  for (int i = 0; i < 32; ++i) ok_text += "[";
  for (int i = 0; i < 32; ++i) ok_text += "]";
  EXPECT_TRUE(variantFromJsonText(ok_text).ok());
  EXPECT_HAS(jsonError("[" + ok_text + "]"), "nesting depth 33 exceeds the limit of 32");
  // Escapes add JSON levels but no Variant level: a value at the limit still reads back.
  Variant v = Bytes("x");
  for (int i = 1; i < 32; ++i) v = Map{{"$map", std::move(v)}};
  Result<Variant> back = variantFromJsonText(variantToJsonText(v));
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back.value(), v);
  // jsoncpp itself must not recurse without bound.
  EXPECT_FALSE(jsonError(std::string(200000, '[')).empty());
}

}  // namespace
}  // namespace skr::flow
