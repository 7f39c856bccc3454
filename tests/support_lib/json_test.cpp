// SPDX-License-Identifier: Apache-2.0
// The module-support library's JSON parser, writer and quoter (skrobot/support/json.hpp).
#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>

#include <limits>
#include <string>

namespace {

using skr::Errc;
using skr::support::JsonLimits;
using skr::support::jsonQuote;
using skr::support::parseJson;
using skr::support::parseJsonObject;
using skr::support::writeJson;

std::string nested(std::size_t depth) {
  return std::string(depth, '[') + std::string(depth, ']');
}

TEST(SupportJson, ParsesAnyRootValue) {
  auto obj = parseJson(R"({"a": [1, 2.5, "x", true, null]})");
  ASSERT_TRUE(obj.ok()) << obj.error().message;
  EXPECT_EQ((*obj)["a"][1].asDouble(), 2.5);
  auto scalar = parseJson("  42 ");
  ASSERT_TRUE(scalar.ok());
  EXPECT_EQ(scalar->asInt(), 42);
}

TEST(SupportJson, SyntaxErrorIsOneLineWithPosition) {
  auto r = parseJson("{\n  \"a\": 1,\n  \"b\": }");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::parse_error);
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("line 3, column 8"), std::string::npos) << r.error().message;
}

TEST(SupportJson, StrictModeRejectsExtensionsAndTrailingText) {
  for (const char* text :
       {"{\"a\":1} x", "{\"a\":1,}", "// c\n{}", "{'a':1}", "[NaN]", "{\"a\":1,\"a\":2}", ""}) {
    auto r = parseJson(text);
    EXPECT_FALSE(r.ok()) << text;
    if (!r.ok()) {
      EXPECT_EQ(r.error().code, Errc::parse_error) << text;
    }
  }
}

TEST(SupportJson, RawControlCharactersAreRefused) {
  // jsoncpp alone takes a NUL for the end of the text and copies raw controls into strings.
  for (const std::string& text : {std::string("{\"a\":1}\0garbage", 15), std::string("\"a\x01b\""),
                                  std::string("[1,\x1f"
                                              "2]"),
                                  std::string("\"tab\there\"")}) {
    auto r = parseJson(text);
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.error().code, Errc::parse_error);
    EXPECT_NE(r.error().message.find("control character 0x"), std::string::npos)
        << r.error().message;
  }
  auto nul = parseJson(std::string("{\"a\":1}\0", 8));
  ASSERT_FALSE(nul.ok());
  EXPECT_NE(nul.error().message.find("0x00 at line 1, column 8"), std::string::npos)
      << nul.error().message;
  EXPECT_TRUE(parseJson("{\r\n\t\"a\": \"\\t\"\n}").ok());  // whitespace and escapes are fine
}

TEST(SupportJson, NestingLimitIsExactAndNeverThrows) {
  EXPECT_TRUE(parseJson(nested(64)).ok());
  auto deep = parseJson(nested(65));
  ASSERT_FALSE(deep.ok());
  EXPECT_EQ(deep.error().code, Errc::limit_exceeded);
  EXPECT_NE(deep.error().message.find("deeper than 64 at line 1, column 65"), std::string::npos)
      << deep.error().message;
  // Far past jsoncpp's own recursion limit (1000 by default), which throws.
  auto very_deep = parseJson(nested(100000), JsonLimits{.max_depth = 64, .max_bytes = 1u << 20});
  ASSERT_FALSE(very_deep.ok());
  EXPECT_EQ(very_deep.error().code, Errc::limit_exceeded);
  // Brackets inside strings do not count.
  EXPECT_TRUE(parseJson("[\"" + std::string(200, '[') + "\\\"{\"]").ok());
  EXPECT_TRUE(parseJson(nested(3), JsonLimits{.max_depth = 3}).ok());
  EXPECT_FALSE(parseJson(nested(4), JsonLimits{.max_depth = 3}).ok());
}

TEST(SupportJson, SizeLimit) {
  auto r = parseJson("[1,2,3]", JsonLimits{.max_bytes = 6});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::limit_exceeded);
  EXPECT_TRUE(parseJson("[1,2,3]", JsonLimits{.max_bytes = 7}).ok());
}

TEST(SupportJson, ObjectRoot) {
  EXPECT_TRUE(parseJsonObject("{}").ok());
  auto r = parseJsonObject("[1]");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::parse_error);
  EXPECT_NE(r.error().message.find("got array"), std::string::npos) << r.error().message;
}

TEST(SupportJson, QuoteEscapesQuotesBackslashesAndControls) {
  EXPECT_EQ(jsonQuote("say \"hi\" \\ now"), R"("say \"hi\" \\ now")");
  EXPECT_EQ(jsonQuote(std::string("a\nb\tc\rd\x01\x1f\x7f\b\f", 12)),
            R"("a\nb\tc\rd\u0001\u001f\u007f\b\f")");
  EXPECT_EQ(jsonQuote(std::string("nul\0x", 5)), R"("nul\u0000x")");
  EXPECT_EQ(jsonQuote(""), "\"\"");
}

TEST(SupportJson, QuoteKeepsValidUtf8AndReplacesInvalidBytes) {
  EXPECT_EQ(jsonQuote("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80"),
            "\"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80\"");
  const std::string bad[] = {
      "\xff",              // never valid
      "\xc3(",             // continuation missing
      "\xc0\xaf",          // overlong '/'
      "\xed\xa0\x80",      // a surrogate
      "\xf4\x90\x80\x80",  // above U+10FFFF
      "\xe2\x82",          // truncated at the end
  };
  for (const auto& b : bad) {
    const std::string q = jsonQuote(b);
    EXPECT_NE(q.find("\xef\xbf\xbd"), std::string::npos) << q;
    // What we write must read back.
    EXPECT_TRUE(parseJson(q).ok()) << q;
  }
  EXPECT_EQ(jsonQuote("\xc3("), "\"\xef\xbf\xbd(\"");
}

TEST(SupportJson, WriterIsCompactAndRoundTrips) {
  Json::Value v(Json::objectValue);
  v["text"] = "he said \"no\"\n";
  v["int"] = Json::Int64(-5);
  v["big"] = Json::UInt64(std::numeric_limits<std::uint64_t>::max());
  v["half"] = 0.5;
  v["whole"] = 2.0;
  v["third"] = 1.0 / 3.0;
  v["list"] = Json::Value(Json::arrayValue);
  v["list"].append(true);
  v["list"].append(Json::Value());
  const std::string text = writeJson(v);
  EXPECT_EQ(text, R"({"big":18446744073709551615,"half":0.5,"int":-5,"list":[true,null],)"
                  R"("text":"he said \"no\"\n","third":0.3333333333333333,"whole":2.0})");
  auto back = parseJson(text);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(*back, v);
}

TEST(SupportJson, WriterNonFiniteIsNullAndKeysAreEscaped) {
  Json::Value v(Json::objectValue);
  v["nan"] = std::numeric_limits<double>::quiet_NaN();
  v["inf"] = std::numeric_limits<double>::infinity();
  v["k\"\x01\xff"] = 1;
  EXPECT_EQ(writeJson(v), "{\"inf\":null,\"k\\\"\\u0001\xef\xbf\xbd\":1,\"nan\":null}");
  EXPECT_EQ(writeJson(Json::Value("x")), "\"x\"");
  EXPECT_EQ(writeJson(Json::Value(Json::arrayValue)), "[]");
  EXPECT_EQ(writeJson(Json::Value(Json::objectValue)), "{}");
}

}  // namespace

namespace skr::support {
namespace {

// RFC 4648 section 10, in the JSON mapping's spelling of bytes.
TEST(SupportJson, BytesAreBase64InTheMappingsObject) {
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
    EXPECT_EQ(writeJson(jsonBytes(plain)), std::string(R"({"$base64":")") + text + "\"}");
  }
  EXPECT_EQ(jsonBytes(std::string("\xFB\xFF", 2))["$base64"].asString(), "+/8=");
}

}  // namespace
}  // namespace skr::support
