// SPDX-License-Identifier: Apache-2.0
// Every FlowProtocol message encodes and decodes back to itself; the byte examples of
// docs/flow-protocol.md are what the code produces; the frame splitter refuses bad lengths.
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/message_table.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <set>
#include <string>

namespace skr::flow {
namespace {

std::string hex(std::string_view bytes) {
  std::string out;
  char b[4];
  for (unsigned char c : bytes) {
    std::snprintf(b, sizeof b, "%02x ", c);
    out += b;
  }
  if (!out.empty()) out.pop_back();
  return out;
}

Variant sample() {
  return Variant(Variant::Map{
      {"int", Variant(int64_t{-42})},
      {"uint", Variant(uint64_t{18446744073709551615ull})},
      {"float", Variant(3.25)},
      {"text", Variant("caffè")},
      {"bytes", Variant(Variant::Bytes{std::string("\x00\xff\x10", 3)})},
      {"list", Variant(Variant::List{Variant(true), Variant(), Variant(false)})},
  });
}

// Fills every field of a message with something that is not its default.
struct Filler {
  int n = 1;
  bool operator()(uint8_t& v) { return v = static_cast<uint8_t>(n++), true; }
  bool operator()(uint16_t& v) { return v = static_cast<uint16_t>(1000 + n++), true; }
  bool operator()(uint32_t& v) { return v = static_cast<uint32_t>(100000 + n++), true; }
  bool operator()(uint64_t& v) { return v = 0x0102030405060708ull + n++, true; }
  bool operator()(std::string& s) { return s = "field-" + std::to_string(n++), true; }
  bool operator()(msg::Text32& t) { return t.text = "long-" + std::to_string(n++), true; }
  bool operator()(msg::Rest& r) { return r.bytes = "payload\x00\x01 bytes", true; }
  bool operator()(Variant& v) { return v = sample(), true; }
  template <class T>
  requires requires(T& t, Filler& f) { t.io(f); }
  bool operator()(T& part) { return part.io(*this); }
  template <class T>
  bool operator()(std::vector<T>& items) {
    items.resize(2);
    for (auto& i : items) i.io(*this);
    return true;
  }
};

TEST(Codec, EveryMessageRoundTripsInBothValueEncodings) {
  int messages = 0;
  forEachMessage([&](auto m) {
    using M = decltype(m);
    Filler fill;
    m.io(fill);
    for (auto enc : {ValueEncoding::binary, ValueEncoding::json}) {
      std::string frame;
      ASSERT_TRUE(encode(frame, m, enc));
      // Header: length of the rest, then the code.
      uint32_t len = 0;
      std::memcpy(&len, frame.data(), 4);
      EXPECT_EQ(len, frame.size() - 4);
      EXPECT_EQ(static_cast<uint8_t>(frame[4]), static_cast<uint8_t>(M::code));
      auto back = decode<M>(std::string_view(frame).substr(5));
      ASSERT_TRUE(back) << codeName(uint8_t(M::code)) << ": " << back.error().message;
      std::string again;
      ASSERT_TRUE(encode(again, back.value(), enc));
      EXPECT_EQ(hex(again), hex(frame)) << codeName(uint8_t(M::code));
    }
    ++messages;
  });
  // Every row of the catalogue has its message among them.
  std::set<uint8_t> codes;
  forEachMessage([&](auto m) { codes.insert(uint8_t(decltype(m)::code)); });
  for (const CodeInfo& row : catalogue()) EXPECT_TRUE(codes.count(row.code)) << row.name;
  EXPECT_GE(messages, int(catalogue().size()));
}

// Tells whether a message ends with a Rest field (whose length is whatever is left).
struct RestProbe {
  bool* found;
  bool operator()(msg::Rest&) { return *found = true, true; }
  template <class T>
  bool operator()(T&) {
    return true;
  }
};

TEST(Codec, TruncatedOrPaddedBodiesAreRefused) {
  forEachMessage([&](auto m) {
    using M = decltype(m);
    Filler fill;
    m.io(fill);
    std::string frame;
    ASSERT_TRUE(encode(frame, m));
    const std::string body = frame.substr(5);
    bool has_rest = false;
    RestProbe probe{&has_rest};
    m.io(probe);
    if (!has_rest) {
      EXPECT_FALSE(decode<M>(body + "x")) << codeName(uint8_t(M::code)) << " took trailing bytes";
    }
    for (size_t cut = 0; cut < body.size(); ++cut) {
      auto r = decode<M>(std::string_view(body).substr(0, cut));
      if (has_rest) continue;  // a shorter payload is a valid payload
      EXPECT_FALSE(r) << codeName(uint8_t(M::code)) << " decoded from " << cut << " of "
                      << body.size() << " bytes";
    }
  });
}

TEST(Codec, ByteExamplesOfTheSpecification) {
  const auto enc = [](const Variant& v) {
    std::string out;
    ByteWriter w(out);
    encodeVariant(v, w);
    return hex(out);
  };
  EXPECT_EQ(enc(Variant(int64_t{1})), "02 01 00 00 00 00 00 00 00");
  EXPECT_EQ(enc(Variant("hi")), "05 02 00 00 00 68 69");
  EXPECT_EQ(enc(Variant(Variant::List{Variant(true), Variant()})), "07 02 00 00 00 01 01 00");
  EXPECT_EQ(enc(Variant(Variant::Map{{"a", Variant(1.5)}})),
            "08 01 00 00 00 01 00 61 04 00 00 00 00 00 00 f8 3f");
  std::string frame;
  ASSERT_TRUE(encode(frame, msg::Subscribe{7, 3}));
  EXPECT_EQ(hex(frame), "07 00 00 00 42 07 00 00 00 03 00");
  frame.clear();
  ASSERT_TRUE(encode(frame, msg::Publish{3, msg::Rest{"ab"}}));
  EXPECT_EQ(hex(frame), "05 00 00 00 44 03 00 61 62");
}

TEST(Codec, JsonTwinOfAValue) {
  std::string frame;
  ASSERT_TRUE(encode(frame, msg::VarSet{"k", Variant(int64_t{5})}, ValueEncoding::json));
  // key "k", then encoding 1 and the JSON text "5".
  EXPECT_EQ(hex(frame.substr(5)), "01 00 6b 01 01 00 00 00 35");
  auto back = decode<msg::VarSet>(std::string_view(frame).substr(5));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->value, Variant(int64_t{5}));
  const std::string bad = std::string("\x01\x00k\x01\x03\x00\x00\x00{{{", 11);
  EXPECT_FALSE(decode<msg::VarSet>(bad));
  EXPECT_FALSE(decode<msg::VarSet>(std::string("\x01\x00k\x07", 4)));  // unknown encoding
}

TEST(Codec, HugeAnnouncedCountsFailWithoutAllocating) {
  // A channel list announcing 4 billion entries in 4 bytes.
  const std::string body("\xff\xff\xff\xff", 4);
  auto r = decode<msg::ChannelList>(body);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("exceeds"), std::string::npos) << r.error().message;
}

TEST(Codec, StringsOverTheirWireLimitAreNotEncoded) {
  std::string out = "keep";
  EXPECT_FALSE(encode(out, msg::VarGet{std::string(70000, 'k')}));
  EXPECT_EQ(out, "keep");
}

TEST(FrameSplitter, FramesLimitsAndPartialInput) {
  FrameSplitter s(100);
  std::string two;
  ASSERT_TRUE(encode(two, msg::Subscribe{1, 2}));
  ASSERT_TRUE(encode(two, msg::Publish{2, msg::Rest{"xyz"}}));
  const auto* p = reinterpret_cast<const uint8_t*>(two.data());
  auto a = s.next(p, two.size());
  ASSERT_EQ(a.status, FrameSplitter::Status::frame);
  EXPECT_EQ(a.code, uint8_t(Code::subscribe));
  auto b = s.next(p + a.consumed, two.size() - a.consumed);
  ASSERT_EQ(b.status, FrameSplitter::Status::frame);
  EXPECT_EQ(b.body.substr(2), "xyz");
  // Every prefix of a frame asks for more, and says how much once the length is known.
  for (size_t n = 0; n < a.consumed; ++n) {
    auto partial = s.next(p, n);
    EXPECT_EQ(partial.status, FrameSplitter::Status::need_more);
    if (n >= 4) {
      EXPECT_EQ(partial.wanted, a.consumed);
    }
  }
  const uint8_t big[] = {101, 0, 0, 0, 0x44};
  EXPECT_EQ(s.next(big, sizeof big).status, FrameSplitter::Status::too_large);
  const uint8_t huge[] = {0xff, 0xff, 0xff, 0xff};  // refused on the length alone
  EXPECT_EQ(s.next(huge, sizeof huge).status, FrameSplitter::Status::too_large);
  const uint8_t empty[] = {0, 0, 0, 0};
  EXPECT_EQ(s.next(empty, sizeof empty).status, FrameSplitter::Status::empty_frame);
}

}  // namespace
}  // namespace skr::flow
