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

// The agent's answers among what the harness's satellite received.
std::vector<Json::Value> answers(const AsrHarness& h) {
  std::vector<Json::Value> out;
  for (const auto& v : h.transcripts) {
    if (v.isMember("heard")) out.push_back(v);
  }
  return out;
}

TEST(AsrAgent, TwoRecognisersHearTheAgentsGrammarAndItAnswersEachUtteranceOnce) {
  TempDir dir;
  AsrHarness h(dir, {}, "asr1", micProps(), kModules);
  ASSERT_TRUE(h.ready()) << h.hubLog() << h.asrLog();
  Child asr2({ASR_BIN, "--input", "guest.mic", "--name", "asr2", "--address", h.address()}, {},
             dir.path() / "asr2.log");
  h.satellite().subscribe("agent.dialogue");
  const auto mode = [&](const std::string& name) {
    flow::Variant answer;
    bool done = false;
    (void)h.satellite().request("guest." + name + ".control", "status", {},
                                [&](const sat::Response& r) {
                                  answer = r.value;
                                  done = true;
                                });
    h.loop().runUntil([&] { return done; }, 10 * kNsPerSec);
    const flow::Variant* m = answer.find("mode");
    return m != nullptr && m->asString() != nullptr ? *m->asString() : std::string();
  };
  // Both recognisers took the agent's grammar (handed over when each appeared).
  ASSERT_TRUE(h.loop().runUntil(
      [&] { return mode("asr1") == "grammar" && mode("asr2") == "grammar"; }, 30 * kNsPerSec))
      << h.hubLog() << h.asrLog() << asr2.output();

  const auto say = [&](const std::string& text) {
    std::vector<Clip> clips{{text, speak(dir.path(), text, "en-us", 150, 22050)}};
    h.stream(concat(clips, 1.0, 22050), 22050, 2.0);
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

}  // namespace
}  // namespace skr::asr::test
