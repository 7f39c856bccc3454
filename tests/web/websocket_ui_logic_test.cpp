// SPDX-License-Identifier: Apache-2.0
// websocket-ui's logic without a browser: what browsers may send, the avatar's behaviour on a
// driven clock, and the viseme timeline.
#include "avatar_behaviour.h"
#include "browser_protocol.h"
#include "source_owner.h"
#include "visemes.h"

#include <gtest/gtest.h>

#include <skrobot/media_frame.hpp>

#include <set>
#include <string>
#include <utility>
#include <vector>

namespace skr::wsui {
namespace {

std::string jpegFrame(std::uint16_t w, std::uint16_t h, std::string body = "\xFF\xD8\xFF\xE0rest") {
  media::FrameHeader hd;
  hd.format = media::Format::jpeg;
  hd.width = w;
  hd.height = h;
  return media::makeFrame(hd, body);
}

TEST(BrowserProtocol, AcceptsCameraMicHelloAndSay) {
  InboundLimits lim;
  EXPECT_TRUE(std::holds_alternative<CameraFrame>(parseInbound(true, jpegFrame(640, 360), lim)));
  media::FrameHeader a;
  a.format = media::Format::pcm_s16le;
  a.channels = 1;
  a.sample_rate = 22050;
  EXPECT_TRUE(std::holds_alternative<MicFrame>(
      parseInbound(true, media::makeFrame(a, std::string(2048, '\0')), lim)));
  auto hello = parseInbound(false, R"({"type":"hello","version":1,"page":"avatar"})", lim);
  ASSERT_TRUE(std::holds_alternative<Hello>(hello));
  EXPECT_EQ(std::get<Hello>(hello).page, "avatar");
  auto say = parseInbound(false, R"({"type":"say","text":"ciao","voice":"it"})", lim);
  ASSERT_TRUE(std::holds_alternative<Say>(say));
  EXPECT_EQ(std::get<Say>(say).voice, "it");
}

int refusal(const Inbound& in) {
  return std::holds_alternative<Refusal>(in) ? std::get<Refusal>(in).close_code : 0;
}

TEST(BrowserProtocol, RefusesWhatIsNotOurs) {
  InboundLimits lim;
  EXPECT_EQ(refusal(parseInbound(true, "\xFF\xD8\xFF raw jpeg without header", lim)),
            kCloseUnsupported);
  EXPECT_EQ(refusal(parseInbound(true, jpegFrame(640, 360, "GIF89a..."), lim)), kCloseUnsupported);
  EXPECT_EQ(refusal(parseInbound(true, jpegFrame(4000, 360), lim)), kCloseUnsupported);
  media::FrameHeader a;
  a.format = media::Format::pcm_s16le;
  a.channels = 2;
  a.sample_rate = 22050;
  EXPECT_EQ(refusal(parseInbound(true, media::makeFrame(a, std::string(64, '\0')), lim)),
            kCloseUnsupported);  // stereo
  a.channels = 1;
  a.sample_rate = 48000;
  EXPECT_EQ(refusal(parseInbound(true, media::makeFrame(a, std::string(64, '\0')), lim)),
            kCloseUnsupported);  // another rate
  EXPECT_EQ(refusal(parseInbound(false, "{not json", lim)), kCloseBadPayload);
  EXPECT_EQ(refusal(parseInbound(false, "[1,2]", lim)), kCloseBadPayload);
  EXPECT_EQ(refusal(parseInbound(false, R"({"type":"launch"})", lim)), kCloseBadPayload);
  EXPECT_EQ(refusal(parseInbound(false, R"({"type":"say","text":""})", lim)), kCloseBadPayload);
  EXPECT_EQ(refusal(parseInbound(false, R"({"type":"hello","version":1} trailing)", lim)),
            kCloseBadPayload);
  EXPECT_EQ(refusal(parseInbound(false, std::string(5000, ' '), lim)), kClosePolicy);
  std::string deep(100, '[');
  EXPECT_EQ(refusal(parseInbound(false, deep, lim)), kCloseBadPayload);
}

TEST(AvatarBehaviour, LooksAtTheLargestFaceThenMotionThenAhead) {
  AvatarOptions o;
  AvatarBehaviour a(o, 7);
  auto g = a.gazeDue(0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->source, "idle");
  // Two faces in a 640x360 frame: the larger one, on the left, wins.
  a.onFaces({{100, 100, 40, 40}, {20, 60, 120, 120}}, 640, 360, 100);
  g = a.gazeDue(100);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->source, "face");
  EXPECT_NEAR(g->x, (80.0 / 640) * 2 - 1, 1e-9);
  EXPECT_NEAR(g->y, (120.0 / 360) * 2 - 1, 1e-9);
  // Nothing new within the rate limit; no repeat of the same target.
  EXPECT_FALSE(a.gazeDue(120));
  EXPECT_FALSE(a.gazeDue(400));
  // Motion does not override a fresh face, but takes over when the face is stale.
  a.onMotion(0.05, std::make_pair(600.0, 180.0), 640, 360, 500);
  EXPECT_FALSE(a.gazeDue(600));
  a.onMotion(0.05, std::make_pair(600.0, 180.0), 640, 360, 1150);
  g = a.gazeDue(1200);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->source, "motion");
  EXPECT_GT(g->x, 0.8);
  // Too little motion is ignored; after the hold the avatar looks ahead.
  a.onMotion(0.0001, std::make_pair(0.0, 0.0), 640, 360, 1300);
  g = a.gazeDue(2000);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->source, "idle");
  EXPECT_EQ(g->x, 0);
}

TEST(AvatarBehaviour, BlinksAtRandomIntervalsWithinBoundsClosingFasterThanOpening) {
  AvatarOptions o;
  AvatarBehaviour a(o, 42);
  std::vector<std::int64_t> starts;
  for (std::int64_t t = 0; t < 600000; t += 10) {
    if (auto b = a.blinkDue(t)) {
      EXPECT_LT(b->close_ms, b->open_ms);
      starts.push_back(t);
    }
  }
  ASSERT_GT(starts.size(), 200u);  // ~2.2 s on average over 10 minutes
  std::int64_t lo = INT64_MAX, hi = 0;
  double sum = 0;
  for (std::size_t i = 1; i < starts.size(); ++i) {
    const std::int64_t d = starts[i] - starts[i - 1];
    lo = std::min(lo, d);
    hi = std::max(hi, d);
    sum += static_cast<double>(d);
  }
  EXPECT_GE(lo, 450);
  EXPECT_LE(hi, 4000 + 10);
  EXPECT_LT(lo, 700);  // random: both ends of the range occur
  EXPECT_GT(hi, 3700);
  EXPECT_NEAR(sum / static_cast<double>(starts.size() - 1), 2225, 200);
}

TEST(AvatarBehaviour, SmilesAtANewFaceAndIsSurprisedByACode) {
  AvatarBehaviour a(AvatarOptions{}, 1);
  EXPECT_FALSE(a.expressionDue());
  a.onFaces({{10, 10, 50, 50}}, 640, 360, 1000);
  auto e = a.expressionDue();
  ASSERT_TRUE(e);
  EXPECT_EQ(e->name, "happy");
  EXPECT_FALSE(a.expressionDue());  // once
  // The same person in view: no new greeting.
  for (std::int64_t t = 1066; t < 5000; t += 66) a.onFaces({{10, 10, 50, 50}}, 640, 360, t);
  EXPECT_FALSE(a.expressionDue());
  // Back after more than greet_after_ms without a face.
  a.onFaces({}, 640, 360, 6000);
  EXPECT_FALSE(a.expressionDue());
  a.onFaces({{10, 10, 50, 50}}, 640, 360, 9000);
  e = a.expressionDue();
  ASSERT_TRUE(e);
  EXPECT_EQ(e->name, "happy");
  a.onCodes(false, 9100);
  EXPECT_FALSE(a.expressionDue());
  a.onCodes(true, 9200);
  e = a.expressionDue();
  ASSERT_TRUE(e);
  EXPECT_EQ(e->name, "surprised");
}

TEST(SourceOwner, OneBrowserFeedsTheChannelUntilItGoesQuietOrLeaves) {
  SourceOwner s(1000);
  EXPECT_TRUE(s.accept(1, 0));
  EXPECT_FALSE(s.accept(2, 500));  // browser 1 is still sending
  EXPECT_TRUE(s.accept(1, 900));
  EXPECT_FALSE(s.accept(2, 1800));
  EXPECT_TRUE(s.accept(2, 1901));  // browser 1 silent for more than a second: handed over
  EXPECT_FALSE(s.accept(1, 1950));
  s.leave(2);
  EXPECT_TRUE(s.accept(1, 1960));  // the owner left: at once
  EXPECT_EQ(s.owner(), 1u);
  EXPECT_EQ(s.ignored(), 3u);
  EXPECT_EQ(s.takeovers(), 3u);
}

TEST(Visemes, TimelineFollowsPhonemesAndEndsAtSilence) {
  // espeak-ng's phonemes of "hello" with stress marks and a pause.
  auto tl =
      visemeTimeline({{"_:", 0}, {"h", 10}, {"@", 60}, {"l", 120}, {"'oU", 180}, {"_", 400}}, 450);
  std::vector<std::string> names;
  for (const auto& v : tl) names.push_back(v.viseme.name);
  EXPECT_EQ(names, (std::vector<std::string>{"sil", "kk", "E", "nn", "O", "sil"}));
  for (std::size_t i = 1; i < tl.size(); ++i) EXPECT_GT(tl[i].t_ms, tl[i - 1].t_ms);
  EXPECT_LE(tl.back().t_ms, 450);
  EXPECT_GT(tl[4].viseme.round, 0.5);
  EXPECT_EQ(visemeFor("m").open, 0);
  EXPECT_GT(visemeFor("a:").open, 0.5);
}

// A typical espeak-ng phoneme for each viseme of the documented table (docs/websocket-ui.md).
TEST(Visemes, EachOfTheFifteenFromATypicalPhoneme) {
  const std::vector<std::pair<std::string, std::string>> typical = {
      {"_:", "sil"}, {"p", "PP"},  {"b", "PP"},  {"m", "PP"},  {"f", "FF"},  {"v", "FF"},
      {"T", "TH"},   {"D", "TH"},  {"t", "DD"},  {"d", "DD"},  {"k", "kk"},  {"g", "kk"},
      {"N", "kk"},   {"h", "kk"},  {"tS", "CH"}, {"dZ", "CH"}, {"S", "CH"},  {"Z", "CH"},
      {"s", "SS"},   {"z", "SS"},  {"n", "nn"},  {"l", "nn"},  {"@L", "nn"}, {"n-", "nn"},
      {"r", "RR"},   {"r-", "RR"}, {"a", "aa"},  {"a#", "aa"}, {"A:", "aa"}, {"A@", "aa"},
      {"aI", "aa"},  {"aU", "aa"}, {"V", "aa"},  {"E", "E"},   {"e@", "E"},  {"eI", "E"},
      {"@", "E"},    {"3:", "E"},  {"i", "I"},   {"i:", "I"},  {"I", "I"},   {"i@", "I"},
      {"j", "I"},    {"O:", "O"},  {"O@", "O"},  {"OI", "O"},  {"oU", "O"},  {"0", "O"},
      {"u:", "U"},   {"U", "U"},   {"U@", "U"},  {"w", "U"}};
  std::set<std::string> produced;
  for (const auto& [ph, name] : typical) {
    EXPECT_EQ(visemeFor(ph).name, name) << ph;
    produced.insert(visemeFor(ph).name);
  }
  // Every name of the list comes from some phoneme, and the shapes differ where they should.
  EXPECT_EQ(produced, std::set<std::string>(kVisemeNames.begin(), kVisemeNames.end()));
  EXPECT_EQ(visemeFor("p").open, 0);
  EXPECT_GT(visemeFor("a:").open, visemeFor("E").open);
  EXPECT_GT(visemeFor("i:").wide, visemeFor("u:").wide);
  EXPECT_GT(visemeFor("u:").round, visemeFor("oU").round);
  EXPECT_GT(visemeFor("tS").round, visemeFor("s").round);
}

TEST(Visemes, StressAndLengthMarksAreStripped) {
  EXPECT_EQ(visemeFor("'a:").name, "aa");
  EXPECT_EQ(visemeFor(",oU").name, "O");
  EXPECT_EQ(visemeFor("%i:").name, "I");
  EXPECT_EQ(visemeFor("'3:").name, "E");
  EXPECT_EQ(visemeFor("',u:").name, "U");
  EXPECT_EQ(visemeFor("tS;").name, "CH");  // a palatalised affricate: not DD
  EXPECT_EQ(visemeFor("'aI@").name, "aa");
  const Viseme plain = visemeFor("oU"), stressed = visemeFor("'oU");
  EXPECT_EQ(stressed.open, plain.open);
  EXPECT_EQ(stressed.wide, plain.wide);
  EXPECT_EQ(stressed.round, plain.round);
}

TEST(Visemes, PausesAndUnknownPhonemesAreSilence) {
  for (const char* ph : {"", "_", "_:", "_!", "_^_", "'", "?", "#", "*", "!", "9"}) {
    const Viseme v = visemeFor(ph);
    EXPECT_EQ(v.name, "sil") << ph;
    EXPECT_EQ(v.open + v.wide + v.round, 0) << ph;
  }
}

// visemeFor only ever answers a name of kVisemeNames, with weights in 0..1.
TEST(Visemes, OnlyNamesOfTheList) {
  const std::set<std::string_view> names(kVisemeNames.begin(), kVisemeNames.end());
  EXPECT_EQ(names.size(), 15u);
  std::vector<std::string> inputs;
  for (int a = 0x20; a < 0x7f; ++a) {
    inputs.emplace_back(1, char(a));
    inputs.push_back("'" + std::string(1, char(a)));
    for (int b = 0x20; b < 0x7f; ++b) inputs.push_back(std::string{char(a), char(b)});
  }
  for (const auto& ph : inputs) {
    const Viseme v = visemeFor(ph);
    ASSERT_TRUE(names.count(v.name)) << "'" << ph << "' -> " << v.name;
    ASSERT_TRUE(v.open >= 0 && v.open <= 1 && v.wide >= 0 && v.wide <= 1 && v.round >= 0 &&
                v.round <= 1)
        << ph;
  }
}

TEST(Visemes, TimelineMergesRepeatsAndEndsWithSilenceAtTheDuration) {
  // No final pause: consecutive phonemes of one viseme are one entry, "sil" ends it.
  auto tl = visemeTimeline(
      {{"m", 0}, {"b", 40}, {"'a:", 80}, {"A:", 150}, {"t", 220}, {"d", 260}, {"a", 300}}, 360);
  std::vector<std::pair<double, std::string>> got;
  for (const auto& v : tl) got.emplace_back(v.t_ms, v.viseme.name);
  EXPECT_EQ(got, (std::vector<std::pair<double, std::string>>{
                     {0, "PP"}, {80, "aa"}, {220, "DD"}, {300, "aa"}, {360, "sil"}}));
  // Nothing: silence at the end.
  tl = visemeTimeline({}, 100);
  ASSERT_EQ(tl.size(), 1u);
  EXPECT_EQ(tl[0].viseme.name, "sil");
  EXPECT_EQ(tl[0].t_ms, 100);
}

}  // namespace
}  // namespace skr::wsui
