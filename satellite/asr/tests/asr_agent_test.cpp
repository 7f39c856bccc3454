// SPDX-License-Identifier: Apache-2.0
// The listening loop end to end: speech made with espeak-ng streams on guest.mic into a hub with
// the agent and speech modules; two skrobot-asr instances listen to it, take the agent's command
// grammar, and the agent answers each utterance once (docs/agent.md, docs/asr.md).
#include "asr_test_util.h"

#include <gtest/gtest.h>

namespace skr::asr::test {
namespace {

constexpr const char* kModules = R"([{"name": "speech", "config": {"voice": "en"}},
    {"name": "agent", "config": {"say": "speech.say", "expression": "", "nao": "",
                                 "faces": "", "codes": ""}}])";

// The agent keeping the microphone (the test's guest.mic) for utterances to re-queue.
constexpr const char* kModulesWithMic = R"([{"name": "speech", "config": {"voice": "en"}},
    {"name": "agent", "config": {"say": "speech.say", "expression": "", "nao": "",
                                 "faces": "", "codes": "", "mic": "guest.mic",
                                 "requeue_after_ms": 1500}}])";

// A request to a service on the harness's satellite, answered within 10 s (null otherwise).
flow::Variant request(AsrHarness& h, const std::string& service, const std::string& command) {
  flow::Variant answer;
  bool done = false;
  (void)h.satellite().request(service, command, {}, [&](const sat::Response& r) {
    answer = r.value;
    done = true;
  });
  h.loop().runUntil([&] { return done; }, 10 * kNsPerSec);
  return answer;
}

std::string modeOf(AsrHarness& h, const std::string& name) {
  const flow::Variant answer = request(h, "guest." + name + ".control", "status");
  const flow::Variant* m = answer.find("mode");
  return m != nullptr && m->asString() != nullptr ? *m->asString() : std::string();
}

// The agent's answers among what the harness's satellite received.
std::vector<Json::Value> answers(const AsrHarness& h) {
  std::vector<Json::Value> out;
  for (const auto& v : h.transcripts) {
    if (v.isMember("heard")) out.push_back(v);
  }
  return out;
}

// A hub with `modules`, skrobot-asr "asr1" (the harness's) and "asr2", both in the agent's grammar,
// and the harness's satellite following agent.dialogue.
struct TwoRecognisers {
  TwoRecognisers(const TempDir& dir, const char* modules)
      : h(dir, {}, "asr1", micProps(), modules),
        asr2({ASR_BIN, "--input", "guest.mic", "--name", "asr2", "--address", h.address()}, {},
             dir.path() / "asr2.log") {
    if (!h.ready()) return;
    h.satellite().subscribe("agent.dialogue");
    // Both took the agent's grammar (handed over when each appeared).
    ready = h.loop().runUntil(
        [&] { return modeOf(h, "asr1") == "grammar" && modeOf(h, "asr2") == "grammar"; },
        30 * kNsPerSec);
  }
  [[nodiscard]] std::string logs() const { return h.hubLog() + h.asrLog() + asr2.output(); }

  AsrHarness h;
  Child asr2;
  bool ready = false;
};

TEST(AsrAgent, TwoRecognisersHearTheAgentsGrammarAndItAnswersEachUtteranceOnce) {
  TempDir dir;
  TwoRecognisers t(dir, kModules);
  ASSERT_TRUE(t.ready) << t.logs();
  AsrHarness& h = t.h;
  Child& asr2 = t.asr2;

  const auto say = [&](const std::string& text) {
    std::vector<Clip> clips{{text, speak(dir.path(), text, "en-us", 150, 22050)}};
    h.stream(concat(clips, 1.0, 22050), 22050, 1.0);  // real time, as a microphone
  };
  say("how are you");
  ASSERT_TRUE(h.loop().runUntil([&] { return !answers(h).empty(); }, 30 * kNsPerSec))
      << h.hubLog() << h.asrLog() << asr2.output();
  const Json::Value first = answers(h)[0];
  EXPECT_EQ(first["intent"].asString(), "how_are_you") << first.toStyledString();
  EXPECT_EQ(first["answer"].asString(), "I am fine, thank you.");
  const std::string by = first["instance"].asString();
  EXPECT_TRUE(by == "guest.asr1" || by == "guest.asr2") << by;
  // The other recogniser's transcript of the same utterance is not answered again; both were
  // paused while the avatar spoke, and listen again after.
  h.loop().runFor(3 * kNsPerSec);
  EXPECT_EQ(answers(h).size(), 1u);
  EXPECT_NE(h.hubLog().find("AGENT-HEARD"), std::string::npos);
  EXPECT_NE(h.asrLog().find("ASR-PAUSE paused"), std::string::npos) << h.asrLog();
  EXPECT_NE(h.asrLog().find("ASR-PAUSE listening again"), std::string::npos) << h.asrLog();

  say("what time is it");
  ASSERT_TRUE(h.loop().runUntil([&] { return answers(h).size() >= 2; }, 30 * kNsPerSec))
      << h.hubLog() << h.asrLog() << asr2.output();
  EXPECT_EQ(answers(h)[1]["intent"].asString(), "time") << answers(h)[1].toStyledString();
  h.loop().runFor(2 * kNsPerSec);
  EXPECT_EQ(answers(h).size(), 2u);
  asr2.signal(SIGTERM);
  EXPECT_EQ(asr2.wait(5000), 0) << asr2.output();
}

TEST(AsrAgent, AnUtteranceWhoseRecogniserDiesIsRecognisedByAnother) {
  TempDir dir;
  TwoRecognisers t(dir, kModulesWithMic);
  ASSERT_TRUE(t.ready) << t.logs();
  AsrHarness& h = t.h;
  Child& asr2 = t.asr2;
  // asr2 does not hear this utterance; asr1 starts on it and dies.
  ASSERT_EQ(request(h, "guest.asr2.control", "pause").find("paused")->asBool(), true);
  std::vector<Clip> clips{{"how are you", speak(dir.path(), "how are you", "en-us", 150, 22050)}};
  bool killed = false;
  h.stream(concat(clips, 1.0, 22050), 22050, 1.0, 20, [&](std::uint64_t) {
    if (killed) return;
    for (const auto& v : h.events) {
      if (v["event"].asString() == "started") {
        ::kill(h.asrPid(), SIGKILL);
        killed = true;
      }
    }
  });
  ASSERT_TRUE(killed) << h.asrLog();
  // The agent hands the utterance's audio to asr2, and answers what asr2 makes of it.
  ASSERT_TRUE(h.loop().runUntil([&] { return !answers(h).empty(); }, 30 * kNsPerSec))
      << h.hubLog() << asr2.output();
  const Json::Value a = answers(h)[0];
  EXPECT_EQ(a["instance"].asString(), "guest.asr2");
  EXPECT_EQ(a["intent"].asString(), "how_are_you") << a.toStyledString();
  EXPECT_NE(asr2.output().find("ASR-GIVEN"), std::string::npos) << asr2.output();
  const flow::Variant state = request(h, "agent.command", "state");
  EXPECT_EQ(state.find("requeued")->asInt64(), 1) << flow::variantToJsonText(state);
  asr2.signal(SIGTERM);
  EXPECT_EQ(asr2.wait(5000), 0) << asr2.output();
}

}  // namespace
}  // namespace skr::asr::test
