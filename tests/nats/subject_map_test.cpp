// SPDX-License-Identifier: Apache-2.0
// The bridge's names: channel names to NATS subjects and database keys to key-value keys, both
// reversible and without collisions (docs/fleet.md, "Subjects").
#include "subject_map.h"
#include "bridge_config.h"

#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>

#include <set>

namespace skr::nats_bridge {
namespace {

const std::string kPrefix = "skrobot.robot1";

TEST(SubjectMap, ChannelNamesBecomeTokensUnderThePrefix) {
  EXPECT_EQ(channelSubject(kPrefix, "guest.camera"), "skrobot.robot1.guest.camera");
  EXPECT_EQ(channelSubject(kPrefix, "video-source.video_hd"),
            "skrobot.robot1.video-source.video_hd");
  EXPECT_EQ(channelSubject(kPrefix, "arm/guest.cam.left"), "skrobot.robot1.arm%2Fguest.cam.left");
  EXPECT_EQ(channelSubject(kPrefix, "_x.y"), "skrobot.robot1.%5Fx.y");  // '_' first: the bridge's
  EXPECT_EQ(channelSubject(kPrefix, "a.._b."), "skrobot.robot1.a.%._b.%");
  EXPECT_EQ(channelSubject(kPrefix, "a*b.>"), "skrobot.robot1.a%2Ab.%3E");
}

TEST(SubjectMap, EverySubjectMadeReadsBackAndDistinctNamesStayDistinct) {
  const std::vector<std::string> names{"guest.camera",
                                       "guest.camera.",
                                       "guest..camera",
                                       "_guest.c",
                                       "%5Fguest.c",
                                       "arm/guest.c",
                                       "arm%2Fguest.c",
                                       "",
                                       ".",
                                       "a b.c",
                                       "é.x",
                                       "x._props"};
  std::set<std::string> subjects;
  for (const auto& n : names) {
    const std::string s = channelSubject(kPrefix, n);
    EXPECT_EQ(subjectChannel(kPrefix, s), n) << s;
    EXPECT_FALSE(badSubject(s, false)) << s;
    EXPECT_TRUE(subjects.insert(s).second) << n << " collides: " << s;
  }
}

TEST(SubjectMap, SubjectsThatNoNameMakesAreRefused) {
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot2.guest.camera"), std::nullopt);  // other hub
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot1"), std::nullopt);
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot1._props.guest.c"), std::nullopt);  // reserved
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot1.a%2fb"), std::nullopt);  // lower-case hex
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot1.a%41b"), std::nullopt);  // 'A' needs none
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot1.a%4"), std::nullopt);    // cut short
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot1.a..b"), std::nullopt);   // empty token
  EXPECT_EQ(subjectChannel(kPrefix, "skrobot.robot1.a<b"), std::nullopt);    // '<' unescaped
  EXPECT_EQ(subjectChannel(kPrefix + "x", "skrobot.robot1x.guest.c"), "guest.c");
}

TEST(SubjectMap, KeysKeepWhatNatsAllowsAndEscapeTheRest) {
  EXPECT_EQ(encodeKey("arm.offset"), "arm.offset");
  EXPECT_EQ(encodeKey("odd key=1"), "odd=20key=3D1");
  EXPECT_EQ(encodeKey(".hidden."), "=2Ehidden=2E");
  EXPECT_EQ(encodeKey("a/b_c-d"), "a/b_c-d");
  for (const std::string k : {"arm.offset", "odd key=1", ".x.", "==", "ü", "a..b", ""}) {
    EXPECT_EQ(decodeKey(encodeKey(k)), k) << k;
  }
  EXPECT_EQ(decodeKey("=41"), std::nullopt);  // 'A' needs no escape: one spelling per key
  EXPECT_EQ(decodeKey("a=2"), std::nullopt);  // cut short
  EXPECT_EQ(decodeKey(".x"), std::nullopt);   // a '.' at an edge is escaped when we write it
}

TEST(SubjectMap, ConfigSubjectsAreCheckedAsNatsTakesThem) {
  EXPECT_FALSE(badSubject("sensors.temp", false));
  EXPECT_FALSE(badSubject("sensors.*.temp", true));
  EXPECT_FALSE(badSubject("sensors.>", true));
  EXPECT_TRUE(badSubject("sensors.>", false));
  EXPECT_TRUE(badSubject("sensors.>.x", true));
  EXPECT_TRUE(badSubject("a..b", true));
  EXPECT_TRUE(badSubject("a b", true));
  EXPECT_TRUE(badSubject("a.b*", true));
  EXPECT_TRUE(badSubject("", true));
}

TEST(BridgeConfig, EveryProblemIsReportedWithItsPath) {
  auto json = support::parseJson(R"({"servers": ["nats://a:4222", ""], "user": "u", "token": "t",
      "tls_cert": "c.pem", "reconnect_min_ms": 500, "reconnect_max_ms": 100,
      "export": ["guest.**", "!"], "import": [{"subject": "x.*", "as": "x", "service": true},
      {"as": "bad name"}, 3], "kv": [{"db": "a"}, {"db": "b", "bucket": "a"}]})");
  ASSERT_TRUE(json);
  BridgeConfig c;
  std::set<std::string> keys;
  for (const auto& p : readConfig(*json, c)) keys.insert(p.key);
  EXPECT_EQ(keys, (std::set<std::string>{"servers[1]", "token", "tls_key", "reconnect_max_ms",
                                         "export", "import[0].subject", "import[1].subject",
                                         "import[1].as", "import[2]", "kv[1].bucket"}));
}

TEST(BridgeConfig, AGoodConfigIsRead) {
  auto json = support::parseJson(R"({"servers": ["nats://a:4222"], "prefix": "fleet.r1",
      "export": ["guest.**", "!guest.debug"], "request_timeout_ms": 100, "reconnect_min_ms": 10,
      "reconnect_max_ms": 100, "queue_bytes": 1000000,
      "import": [{"subject": "s.>", "as": "all", "mime": "text/plain"},
                 {"subject": "svc.add", "as": "add", "service": true, "timeout_ms": 50}],
      "kv": [{"db": "calibration"}]})");
  ASSERT_TRUE(json);
  BridgeConfig c;
  EXPECT_TRUE(readConfig(*json, c).empty());
  EXPECT_EQ(c.prefix, "fleet.r1");
  EXPECT_TRUE(c.exports.selects("guest.cam"));
  EXPECT_FALSE(c.exports.selects("guest.debug"));
  ASSERT_EQ(c.imports.size(), 2u);
  EXPECT_EQ(c.imports[0].mime, "text/plain");
  EXPECT_TRUE(c.imports[1].service);
  EXPECT_EQ(c.imports[1].timeout_ms, 50);
  ASSERT_EQ(c.kv.size(), 1u);
  EXPECT_EQ(c.kv[0].bucket, "calibration");  // the database's name by default
}

}  // namespace
}  // namespace skr::nats_bridge
