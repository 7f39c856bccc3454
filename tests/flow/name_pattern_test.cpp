// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/name_pattern.h>

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace skr::flow {
namespace {

bool match(const char* pattern, const char* name) {
  auto p = NamePattern::parse(pattern);
  EXPECT_TRUE(p.ok()) << pattern << ": " << p.error().message;
  return p.ok() && p->matches(name);
}

TEST(NamePattern, LiteralMatchesOnlyItself) {
  EXPECT_TRUE(match("guest.camera", "guest.camera"));
  EXPECT_FALSE(match("guest.camera", "guest.camera2"));
  EXPECT_FALSE(match("guest.camera", "guest.camer"));
  EXPECT_FALSE(match("guest.camera", "Guest.camera"));
  EXPECT_TRUE(NamePattern::parse("guest.camera")->isLiteral());
  EXPECT_FALSE(NamePattern::parse("guest.*")->isLiteral());
}

TEST(NamePattern, StarStaysWithinOnePart) {
  EXPECT_TRUE(match("guest.*", "guest.camera"));
  EXPECT_FALSE(match("guest.*", "guest.camera.left"));
  EXPECT_TRUE(match("*.faces", "face-detect.faces"));
  EXPECT_FALSE(match("*.faces", "arm/face-detect.faces"));
  EXPECT_TRUE(match("face-*.faces", "face-detect.faces"));
  EXPECT_TRUE(match("face-*.faces", "face-.faces"));  // '*' may be empty
  EXPECT_TRUE(match("video-*.frames", "video-source.frames"));
  EXPECT_FALSE(match("video-*.frames", "video-source.debug.frames"));
}

TEST(NamePattern, DoubleStarCrossesParts) {
  EXPECT_TRUE(match("guest.**", "guest.camera.left"));
  EXPECT_TRUE(match("**", "arm/guest.camera"));
  EXPECT_TRUE(match("**.faces", "arm/face-detect.faces"));
  EXPECT_TRUE(match("arm/**", "arm/guest.x"));
  EXPECT_FALSE(match("arm/**", "leg/guest.x"));
  EXPECT_TRUE(match("*/guest.*", "arm/guest.x"));
  EXPECT_FALSE(match("*/guest.*", "guest.x"));
  EXPECT_TRUE(match("a.**.z", "a.b.c.z"));
  EXPECT_TRUE(match("a.**.z", "a..z"));
  EXPECT_FALSE(match("a.**.z", "a.z"));
}

TEST(NamePattern, QuestionMarkIsOneCharacterOfAPart) {
  EXPECT_TRUE(match("face-?etect.*", "face-detect.faces"));
  EXPECT_FALSE(match("guest?camera", "guest.camera"));
  EXPECT_FALSE(match("guest.?", "guest.ab"));
}

TEST(NamePattern, BacktracksAcrossManyStars) {
  // A naive recursive matcher takes exponential time here.
  const std::string name(200, 'a');
  EXPECT_FALSE(match("*a*a*a*a*a*a*a*a*a*a*a*a*b", name.c_str()));
  EXPECT_TRUE(match("**a**a**a**a**a**a**a**a**a", name.c_str()));
}

TEST(NamePattern, RefusesWhatNoNameHolds) {
  for (const char* bad : {"", "a b", "a\\b", "a\"b", "a***", "a\tb"}) {
    auto p = NamePattern::parse(bad);
    EXPECT_FALSE(p.ok()) << bad;
    if (!p.ok()) {
      EXPECT_EQ(p.error().code, Errc::invalid_argument);
    }
  }
}

TEST(NameFilter, IncludesMinusExcludes) {
  auto f = NameFilter::parse({"camera.*", "!camera.debug"});
  ASSERT_TRUE(f.ok());
  EXPECT_TRUE(f->selects("camera.left"));
  EXPECT_FALSE(f->selects("camera.debug"));
  EXPECT_FALSE(f->selects("mic.raw"));

  auto only_excludes = NameFilter::parse({"!**.debug"});
  ASSERT_TRUE(only_excludes.ok());
  EXPECT_TRUE(only_excludes->selects("camera.left"));
  EXPECT_FALSE(only_excludes->selects("camera.debug"));

  auto none = NameFilter::parse({});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  EXPECT_FALSE(none->selects("camera.left"));
}

TEST(NameFilter, ErrorNamesTheEntry) {
  auto f = NameFilter::parse({"ok.*", "bad name"});
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("pattern 2 'bad name'"), std::string::npos) << f.error().message;
}

}  // namespace
}  // namespace skr::flow
