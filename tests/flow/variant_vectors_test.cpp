// SPDX-License-Identifier: Apache-2.0
// The binary Variant vectors shared with the JavaScript library (tests/js/vectors/variant.json,
// also read by tests/js/variant.test.mjs): each good vector decodes and encodes back to the same
// bytes, each bad one is refused with the reason it names. Both codecs thus agree byte for byte.
#include <skrobot/runtime/flow/bytes.h>
#include <skrobot/runtime/flow/variant.h>

#include <gtest/gtest.h>
#include <json/reader.h>

#include <fstream>
#include <sstream>
#include <string>

namespace {

using namespace skr::flow;

Json::Value vectors() {
  std::ifstream in(std::string(SKROBOT_SOURCE_DIR) + "/tests/js/vectors/variant.json");
  Json::Value root;
  Json::CharReaderBuilder b;
  std::string errors;
  EXPECT_TRUE(Json::parseFromStream(b, in, &root, &errors)) << errors;
  return root;
}

std::string unhex(const std::string& hex) {
  std::string out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

std::string hexOf(const std::string& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (unsigned char c : bytes) {
    out.push_back(digits[c >> 4]);
    out.push_back(digits[c & 15]);
  }
  return out;
}

// The whole input as one value: trailing bytes are an error, as in a frame.
skr::Result<Variant> decodeAll(const std::string& bytes) {
  ByteReader in(bytes);
  auto v = decodeVariant(in);
  if (v && !in.empty()) {
    return skr::makeError(skr::Errc::protocol_error,
                          std::to_string(in.remaining()) + " trailing bytes");
  }
  return v;
}

TEST(VariantVectors, GoodVectorsDecodeAndEncodeBackByteExact) {
  const Json::Value root = vectors();
  ASSERT_GE(root["good"].size(), 20u);
  for (const Json::Value& v : root["good"]) {
    const std::string name = v["name"].asString();
    const std::string hex = v["hex"].asString();
    auto decoded = decodeAll(unhex(hex));
    ASSERT_TRUE(decoded) << name << ": " << decoded.error().message;
    std::string again;
    ByteWriter w(again);
    encodeVariant(*decoded, w);
    EXPECT_EQ(hexOf(again), hex) << name;
  }
}

TEST(VariantVectors, BadVectorsAreRefusedForTheirReason) {
  const Json::Value root = vectors();
  ASSERT_GE(root["bad"].size(), 10u);
  for (const Json::Value& v : root["bad"]) {
    const std::string name = v["name"].asString();
    auto decoded = decodeAll(unhex(v["hex"].asString()));
    ASSERT_FALSE(decoded) << name << " decoded";
    EXPECT_NE(decoded.error().message.find(v["why"].asString()), std::string::npos)
        << name << ": " << decoded.error().message;
  }
}

}  // namespace
