// SPDX-License-Identifier: Apache-2.0
// websocket-ui's logic without a browser: what browsers may send, the avatar's behaviour on a
// driven clock, and the viseme timeline.
#include "avatar_behaviour.h"
#include "browser_protocol.h"
#include "source_owner.h"
#include "visemes.h"

#include <gtest/gtest.h>

#include <skrobot/media_frame.hpp>

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

TEST(Visemes, TimelineFollowsPhonemesAndEndsAtRest) {
  // espeak-ng's phonemes of "hello" with stress marks and a pause.
  auto tl =
      visemeTimeline({{"_:", 0}, {"h", 10}, {"@", 60}, {"l", 120}, {"'oU", 180}, {"_", 400}}, 450);
  ASSERT_GE(tl.size(), 5u);
  EXPECT_EQ(tl.front().viseme.name, "rest");
  for (std::size_t i = 1; i < tl.size(); ++i) EXPECT_GT(tl[i].t_ms, tl[i - 1].t_ms);
  EXPECT_EQ(tl.back().viseme.name, "rest");
  EXPECT_LE(tl.back().t_ms, 450);
  bool round = false;
  for (const auto& v : tl) round = round || (v.viseme.name == "OO" && v.viseme.round > 0.5);
  EXPECT_TRUE(round);
  EXPECT_EQ(visemeFor("m").name, "MBP");
  EXPECT_EQ(visemeFor("m").open, 0);
  EXPECT_GT(visemeFor("a:").open, 0.5);
  EXPECT_EQ(visemeFor("i").name, "EE");
}

}  // namespace
}  // namespace skr::wsui
