// SPDX-License-Identifier: Apache-2.0
// speech through the hub: requests on speech.say, PCM on speech.voice, timelines on
// speech.phonemes, as the avatar's browser sees them.
#include "audio_test_util.h"

namespace skr::test {
namespace {

using namespace skr::test::audio;
using flow::Code;
using flow::Variant;
namespace msg = flow::msg;

class Speech : public ModuleFixture {
 protected:
  void start(const std::string& config = R"({"max_text":300,"queue_max":2})") {
    startHub();
    ASSERT_TRUE(startModule("speech", config).empty());
    listener_.emplace(flowClient(), syncClient());
    ASSERT_TRUE(listener_->subscribe("speech.voice"));
    ASSERT_TRUE(listener_->subscribe("speech.phonemes"));
    auto say = as<msg::ChannelInfoReply>(listener_->sync().call(msg::ChanInfoByName{"speech.say"}));
    ASSERT_TRUE(say);
    say_ = say->info.id;
  }
  // A synchronous call on speech.say; the answer as JSON.
  Json::Value call(const std::string& command, const std::string& value_json) {
    auto v = flow::variantFromJsonText(value_json);
    EXPECT_TRUE(v) << value_json;
    auto reply = as<msg::ReplyValue>(
        listener_->sync().call(msg::ServiceCall{say_, kWaitMs, command, v.value()}));
    EXPECT_TRUE(reply);
    if (!reply) return {};
    return reply->value.toJson();
  }
  // Collects voice frames until `samples` samples arrived; returns them, checking the counter.
  std::vector<int16_t> voiceSamples(size_t from_frame, uint64_t first_seq, size_t samples) {
    std::vector<int16_t> out;
    EXPECT_TRUE(listener_->collect([&] {
      size_t n = 0;
      const auto& frames = listener_->received["speech.voice"];
      for (size_t i = from_frame; i < frames.size(); ++i) {
        n += media::sampleCount(*media::parseFrame(frames[i]));
      }
      return n >= samples;
    }));
    uint64_t seq = first_seq;
    const auto& frames = listener_->received["speech.voice"];
    for (size_t i = from_frame; i < frames.size() && out.size() < samples; ++i) {
      auto f = media::parseFrame(frames[i]);
      EXPECT_TRUE(f);
      EXPECT_EQ(f->header.seq, seq);
      EXPECT_EQ(f->header.sample_rate, 22050u);
      EXPECT_EQ(f->header.channels, 1u);
      auto s = samplesOf(*f);
      seq += s.size();
      out.insert(out.end(), s.begin(), s.end());
    }
    return out;
  }
  // Checks one utterance: answer, timeline and audio. Returns the samples count.
  uint64_t checkUtterance(const Json::Value& answer, const Json::Value& timeline,
                          const std::string& text, const std::string& voice, uint64_t start_seq,
                          size_t from_frame, int words) {
    EXPECT_FALSE(answer.isMember("error")) << answer.toStyledString();
    const int duration = answer["duration_ms"].asInt();
    const uint64_t samples = answer["samples"].asUInt64();
    EXPECT_EQ(timeline["utterance"], answer["utterance"]);
    EXPECT_EQ(timeline["start_seq"].asUInt64(), start_seq);
    EXPECT_EQ(timeline["sample_rate"].asUInt(), 22050u);
    EXPECT_EQ(timeline["duration_ms"].asInt(), duration);
    EXPECT_EQ(timeline["text"].asString(), text);
    EXPECT_EQ(timeline["voice"].asString(), voice);
    EXPECT_EQ(static_cast<uint64_t>(duration), samples * 1000 / 22050);
    // Plausible: at 175 words per minute a word takes ~340 ms; allow 150..1000 ms per word.
    EXPECT_GE(duration, 150 * words) << text;
    EXPECT_LE(duration, 1000 * words) << text;
    const Json::Value& ph = timeline["phonemes"];
    EXPECT_EQ(ph.size(), answer["phonemes"].asUInt());
    EXPECT_GE(ph.size(), static_cast<unsigned>(2 * words));
    int last = -1;
    for (const auto& p : ph) {
      EXPECT_FALSE(p["ph"].asString().empty());
      EXPECT_GT(p["start_ms"].asInt(), last) << "not strictly increasing";
      last = p["start_ms"].asInt();
    }
    EXPECT_LT(last, duration) << "the timeline ends after the audio";
    EXPECT_GE(timeline["words"].size(), 1u);

    const auto pcm = voiceSamples(from_frame, start_seq, samples);
    EXPECT_EQ(pcm.size(), samples);
    double energy = 0;
    for (int16_t s : pcm) energy += static_cast<double>(s) * s;
    const double rms_db =
        10 * std::log10(energy / static_cast<double>(pcm.size()) / (32768.0 * 32768.0));
    EXPECT_GT(rms_db, -40) << "speech should not be silent";
    return samples;
  }
  Json::Value timeline(size_t i) {
    EXPECT_TRUE(listener_->collect([&] { return listener_->count("speech.phonemes") > i; }));
    return *parseJson(listener_->received["speech.phonemes"].at(i));
  }

  std::optional<Listener> listener_;
  uint16_t say_ = 0;
};

TEST_F(Speech, EnglishThenItalianWithTimelinesBeforeTheirAudio) {
  start();
  auto props = listener_->channelProps("speech.voice");
  ASSERT_TRUE(props);
  EXPECT_EQ(*props->find("sample_rate"), Variant(int64_t{22050}));
  EXPECT_EQ(*props->find("format"), Variant("s16le"));
  EXPECT_EQ(*props->find("encoding"), Variant("s16le"));
  EXPECT_EQ(*props->find("message_encoding"), Variant("skrobot.media"));

  const std::string en = "Hello, I am the robot. Nice to meet you.";
  const Json::Value a = call("say", R"({"text":")" + en + R"("})");
  const uint64_t n1 = checkUtterance(a, timeline(0), en, "en", 0, 0, 9);
  EXPECT_EQ(a["utterance"].asInt(), 1);

  const size_t frames_before = listener_->count("speech.voice");
  const std::string it = "Ciao, sono il robot. Piacere di conoscerti, è una bella giornata.";
  const Json::Value b =
      call("say", R"({"text":")" + it + R"(","voice":"it","rate":150,"pitch":60})");
  checkUtterance(b, timeline(1), it, "it", n1, frames_before, 11);
  EXPECT_EQ(b["utterance"].asInt(), 2);

  // Each timeline arrived before the first audio frame of its utterance.
  std::vector<std::string> firsts;
  for (const std::string& ch : listener_->order) {
    if (firsts.empty() || firsts.back() != ch) firsts.push_back(ch);
  }
  EXPECT_EQ(firsts, (std::vector<std::string>{"speech.phonemes", "speech.voice", "speech.phonemes",
                                              "speech.voice"}));
}

TEST_F(Speech, BadRequestsAreAnsweredWithErrors) {
  start();
  auto error = [&](const std::string& command, const std::string& value) {
    const Json::Value r = call(command, value);
    return r.isMember("error") ? r["error"].asString() : std::string("(none)");
  };
  EXPECT_NE(error("say", R"({"text":"   "})").find("empty"), std::string::npos);
  EXPECT_NE(error("say", R"({"text":")" + std::string(301, 'a') + R"("})").find("too long"),
            std::string::npos);
  EXPECT_NE(error("say", R"({"text":"hi","voice":"xx-no-such-voice"})").find("unknown voice"),
            std::string::npos);
  EXPECT_NE(error("say", R"({"text":"hi","rate":5})").find("rate"), std::string::npos);
  EXPECT_NE(error("say", R"({"text":"hi","pitch":101})").find("pitch"), std::string::npos);
  EXPECT_NE(error("shout", R"({"text":"hi"})").find("unknown command"), std::string::npos);
  EXPECT_NE(error("say", R"([1,2])").find("text"), std::string::npos);
  // After all that, speech still works; a plain string is accepted too.
  const Json::Value ok = call("say", R"("Still here.")");
  EXPECT_FALSE(ok.isMember("error"));
  EXPECT_GT(ok["samples"].asInt(), 0);
}

TEST_F(Speech, TheQueueIsBoundedAndServedInOrder) {
  start(R"({"max_text":5000,"queue_max":2})");
  // Twelve long requests in one write: the worker cannot finish one before the loop read them
  // all, so at most 1 (in synthesis) + 2 (queued) are taken and the others are refused.
  std::string text;
  for (int i = 0; i < 40; ++i) text += "This is a long sentence for the queue test. ";
  std::string burst;
  for (uint32_t tag = 1; tag <= 12; ++tag) {
    ASSERT_TRUE(flow::encode(burst, msg::ServiceRequest{tag, say_, "say", Variant(text)}));
  }
  ASSERT_TRUE(listener_->flow().sendRaw(burst));
  std::map<uint32_t, Json::Value> answers;
  while (answers.size() < 12) {
    auto r =
        as<msg::EvServiceResponse>(listener_->flow().waitFor(Code::ev_service_response, kWaitMs));
    ASSERT_TRUE(r);
    answers[r->tag] = r->value.toJson();
  }
  int busy = 0;
  int64_t last_id = 0;
  for (auto& [tag, v] : answers) {
    if (v.isMember("error")) {
      EXPECT_NE(v["error"].asString().find("busy"), std::string::npos);
      ++busy;
    } else {
      EXPECT_GT(v["utterance"].asInt64(), last_id) << "served out of order";
      last_id = v["utterance"].asInt64();
    }
  }
  EXPECT_GE(busy, 9);
  EXPECT_EQ(answers[1]["utterance"].asInt(), 1);
}

}  // namespace
}  // namespace skr::test
