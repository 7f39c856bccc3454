// SPDX-License-Identifier: Apache-2.0
// skrobot-asr against a hub: speech made with espeak-ng (the commands are the benchmark's first
// set, whose rejection measures were looked at when the limits were chosen) and a real recording
// from pocketsphinx-testdata, streamed as one continuous audio channel with silence between
// utterances; the transcripts are checked against word-error-rate thresholds per mode.
#include "asr_test_util.h"

#include <gtest/gtest.h>

namespace skr::asr::test {
namespace {

// Transcripts matched to clips by time: the one whose speech overlaps the clip most.
std::vector<const Json::Value*> match(const std::vector<Clip>& clips,
                                      const std::vector<Json::Value>& transcripts) {
  std::vector<const Json::Value*> out(clips.size(), nullptr);
  for (std::size_t i = 0; i < clips.size(); ++i) {
    double best = 0;
    for (const auto& t : transcripts) {
      const double overlap = std::min(clips[i].end_s, t["end"].asDouble()) -
                             std::max(clips[i].start_s, t["start"].asDouble());
      if (overlap > best) {
        best = overlap;
        out[i] = &t;
      }
    }
  }
  return out;
}

double wer(const std::vector<Clip>& clips, const std::vector<const Json::Value*>& heard) {
  int errors = 0, total = 0;
  for (std::size_t i = 0; i < clips.size(); ++i) {
    const std::string hyp = heard[i] ? (*heard[i])["text"].asString() : "";
    errors += wordErrors(clips[i].text, hyp);
    total += static_cast<int>(words(clips[i].text).size());
  }
  return total > 0 ? static_cast<double>(errors) / total : 0;
}

const std::vector<Said> kOutOfGrammar = {
    {"the weather is lovely this morning", "en-us", 150},
    {"please bring me a cup of coffee", "en+f2", 150},
    {"my cat likes to sleep on the sofa", "en", 150},
};

// The benchmark's command set, the commands in voices the rejection's limits were not chosen on,
// then the sentences outside the grammar, streamed at 8x real time into skrobot-asr started with
// `extra` options: commands heard, the rest rejected.
void grammarRun(const std::vector<std::string>& extra) {
  TempDir dir("asr-grammar");
  const auto gram = dir.write("robot.gram", kCommandGrammar);
  auto clips = make(dir, kCommands);
  const auto first = static_cast<std::ptrdiff_t>(clips.size());
  for (auto& c : make(dir, kUnseenCommands)) clips.push_back(std::move(c));
  const std::size_t commands = clips.size();
  for (auto& c : make(dir, kOutOfGrammar)) clips.push_back(std::move(c));
  const auto stream = concat(clips, 1.0, 22050);

  // Streamed faster than real time: however slow this build and machine, nothing is dropped.
  std::vector<std::string> args = {"--grammar", gram.string(), "--max-behind-s", "3600"};
  args.insert(args.end(), extra.begin(), extra.end());
  AsrHarness h(dir, args);
  ASSERT_TRUE(h.ready()) << h.asrLog();
  h.stream(stream, 22050, 8);
  ASSERT_TRUE(h.waitTranscripts(clips.size(), 120000)) << h.asrLog();
  h.loop().runFor(500 * kNsPerMs);  // anything extra (a split utterance) shows too
  EXPECT_EQ(h.transcripts.size(), clips.size()) << h.asrLog();

  const auto heard = match(clips, h.transcripts);
  const auto all = static_cast<std::ptrdiff_t>(commands);
  const std::vector<Clip> set(clips.begin(), clips.begin() + first);
  const std::vector<const Json::Value*> set_heard(heard.begin(), heard.begin() + first);
  const std::vector<Clip> unseen(clips.begin() + first, clips.begin() + all);
  const std::vector<const Json::Value*> unseen_heard(heard.begin() + first, heard.begin() + all);
  for (std::size_t i = 0; i < clips.size(); ++i) {
    std::printf("  said \"%s\" heard \"%s\"%s (score %.2f, unplaced %.2f)\n", clips[i].text.c_str(),
                heard[i] ? (*heard[i])["text"].asString().c_str() : "(nothing)",
                heard[i] && (*heard[i])["rejected"].asBool() ? " (rejected)" : "",
                heard[i] ? (*heard[i])["reject_score"].asDouble() : 0,
                heard[i] ? (*heard[i])["unplaced"].asDouble() : 0);
  }
  const double w = wer(set, set_heard), wu = wer(unseen, unseen_heard);
  std::printf("grammar WER %.1f%% over the command set, %.1f%% in the unseen voices\n", 100 * w,
              100 * wu);
  // The target (issue 19) on the command set: under 5%; measured 2.9% (14.7% with pocketsphinx's
  // default beams). The unseen voices: 4.3% here, after the set; 10.9% when a fresh recogniser
  // starts with them (its live cepstral mean not yet adapted). A bound, so that it cannot get
  // worse.
  EXPECT_LT(w, 0.05) << h.asrLog();
  EXPECT_LT(wu, 0.15) << h.asrLog();
  for (std::size_t i = 0; i < clips.size(); ++i) {
    ASSERT_NE(heard[i], nullptr) << clips[i].text;
    const auto& t = *heard[i];
    EXPECT_EQ(t["mode"].asString(), "grammar");
    EXPECT_EQ(t["instance"].asString(), "asr");
    EXPECT_FALSE(t["cut"].asBool());
    EXPECT_FALSE(t["dropped"].asBool()) << clips[i].text << " (the recogniser fell behind)";
    // Times on the audio clock: within the clip, give or take the VAD's resolution.
    EXPECT_NEAR(t["start"].asDouble(), clips[i].start_s, 0.25) << clips[i].text;
    // espeak-ng's files end with up to half a second of silence.
    EXPECT_LT(t["end"].asDouble(), clips[i].end_s + 0.25) << clips[i].text;
    EXPECT_GT(t["end"].asDouble(), clips[i].end_s - 0.7) << clips[i].text;
    // What the decision was made on is in the transcript, for tuning.
    EXPECT_TRUE(t.isMember("reject_score")) << clips[i].text;
    EXPECT_TRUE(t.isMember("unplaced")) << clips[i].text;
    if (i < commands) {
      // A rejected command of the unseen voices counts in their WER.
      if (i >= static_cast<std::size_t>(first) && t["rejected"].asBool()) continue;
      EXPECT_FALSE(t["rejected"].asBool()) << clips[i].text;
      ASSERT_FALSE(t["words"].empty()) << clips[i].text;
      EXPECT_GE(t["words"][0]["start"].asDouble(), t["start"].asDouble() - 0.25);
    } else {
      // Out of the grammar: heard, not understood.
      EXPECT_TRUE(t["rejected"].asBool()) << clips[i].text << " heard as " << t["text"];
      EXPECT_EQ(t["text"].asString(), "");
    }
  }
}

TEST(AsrRecognition, GrammarModeCommandsAndRejection) {
  grammarRun({});
}

// The second rule alone (the score's threshold out of reach): out-of-grammar speech is rejected
// because the grammar's path leaves most of it to silence and fillers.
TEST(AsrRecognition, SpeechTheGrammarCannotPlaceIsRejected) {
  grammarRun({"--reject-threshold", "1000"});
}

TEST(AsrRecognition, DictationOfSentencesAndARealRecording) {
  TempDir dir("asr-dictation");
  std::vector<Clip> clips = make(dir, {
                                          {"go forward ten meters", "en-us", 150},
                                          {"what time is it", "en+f2", 130},
                                          {"the robot is in the kitchen", "en", 150},
                                          {"please open the door", "en-us", 170},
                                      });
  // The real recording (16 kHz) at the stream's rate.
  clips.push_back({"go forward ten meters",
                   soxTo(dir.path(), POCKETSPHINX_TESTDATA "/goforward.raw", 22050, true)});
  const auto stream = concat(clips, 1.0, 22050);

  AsrHarness h(dir, {"--max-behind-s", "3600"});  // faster than real time: nothing dropped
  ASSERT_TRUE(h.ready()) << h.asrLog();
  h.stream(stream, 22050, 4);
  ASSERT_TRUE(h.waitTranscripts(clips.size(), 120000)) << h.asrLog();
  const auto heard = match(clips, h.transcripts);
  for (std::size_t i = 0; i < clips.size(); ++i) {
    std::printf("  said \"%s\" heard \"%s\"\n", clips[i].text.c_str(),
                heard[i] ? (*heard[i])["text"].asString().c_str() : "(nothing)");
  }
  const double w = wer(clips, heard);
  std::printf("dictation WER %.1f%%\n", 100 * w);
  // Measured 68% (docs/asr.md): the generic language model on espeak-ng's formant voices is poor,
  // the real recording is exact. This bound catches a broken pipeline (nothing heard, or
  // utterances split: 100% and more), and the recording is checked word for word below.
  EXPECT_LT(w, 0.85) << h.asrLog();
  ASSERT_NE(heard.back(), nullptr);
  EXPECT_EQ((*heard.back())["text"].asString(), "go forward ten meters") << h.asrLog();
  EXPECT_EQ((*heard.back())["mode"].asString(), "dictation");
  EXPECT_GT((*heard.back())["confidence"].asDouble(), 0.3);
}

TEST(AsrRecognition, ControlSetsTheGrammarPausesAndResumes) {
  TempDir dir("asr-control");
  auto clips = make(dir, {{"turn left", "en-us", 150}});
  const auto speech = concat(clips, 0.6, 22050);
  AsrHarness h(dir, {});
  ASSERT_TRUE(h.ready()) << h.asrLog();
  auto status = h.control("status");
  EXPECT_EQ(*status.find("mode")->asString(), "dictation");

  // Keywords hand over a command grammar; a word outside the dictionary is refused.
  flow::Variant bad = flow::Variant::Map{{"jsgf", flow::Variant("#JSGF V1.0; grammar g; public "
                                                                "<c> = zzqxj;")}};
  EXPECT_NE(h.control("set_grammar", bad).find("error"), nullptr);
  flow::Variant keywords = flow::Variant::Map{
      {"keywords", flow::Variant::List{flow::Variant("turn left"), flow::Variant("stop")}}};
  const auto set = h.control("set_grammar", keywords);
  ASSERT_NE(set.find("mode"), nullptr) << flow::variantToJsonText(set);
  EXPECT_EQ(*set.find("mode")->asString(), "grammar");

  // Paused: nothing is heard.
  EXPECT_TRUE(h.control("pause").find("paused")->asBool().value_or(false));
  h.stream(speech, 22050, 0);
  EXPECT_FALSE(h.waitTranscripts(1, 1500));
  EXPECT_EQ(*h.control("status").find("state")->asString(), "paused");

  // Resumed: the same speech is heard, in grammar mode.
  (void)h.control("resume");
  h.stream(speech, 22050, 0);
  ASSERT_TRUE(h.waitTranscripts(1, 10000)) << h.asrLog();
  EXPECT_EQ(h.transcripts[0]["mode"].asString(), "grammar");
  EXPECT_EQ(h.transcripts[0]["text"].asString(), "turn left");

  const auto back = h.control("set_mode", flow::Variant::Map{{"mode", flow::Variant("dictation")}});
  EXPECT_EQ(*back.find("mode")->asString(), "dictation");
  status = h.control("status");
  EXPECT_EQ(status.find("utterances")->asInt64().value_or(0), 1);
  EXPECT_NE(h.control("no_such_command").find("error"), nullptr);
}

}  // namespace
}  // namespace skr::asr::test
