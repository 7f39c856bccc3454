// SPDX-License-Identifier: Apache-2.0
// The agent module in a hub process with the real speech and nao-bridge (simulated) modules:
// recognisers and detectors are satellites that publish what a skrobot-asr, face-detect and
// qrcode would, and record what the agent asks of them.
#include "named_hub.h"

#include <sys/stat.h>

#include <skrobot/support/json.hpp>

#include <fstream>
#include <future>

namespace skr::sat::test {
namespace {

using flow::Variant;

Json::Value json(const std::string& text) {
  auto v = support::parseJson(text);
  return v ? *v : Json::Value();
}

// A recogniser as skrobot-asr shows itself: "<name>.transcript" and a "<name>.control" service
// whose requests it records as "req:<command>:<value>".
struct Recogniser {
  Recogniser(NamedHub& hub, const std::string& name) : name(name), sat(hub.satellite(name)) {
    EXPECT_TRUE(sat->on([&](Satellite& s) {
      s.serviceRequest.connect(&s, [&s, this](const Request& r) {
        sat->events.add("req:" + r.command + ":" + flow::variantToJsonText(r.value));
        (void)s.respond(r, Variant::Map{{"ok", true}});
      });
      return s.addChannel({.name = name + ".transcript", .mime = "application/json"}) &&
             s.addChannel({.name = name + ".control", .kind = flow::ChannelKind::service});
    }));
  }
  // Waits until the agent listens, then says `text` as heard from start_s to end_s.
  void hear(const std::string& text, double start_s, double end_s) {
    EXPECT_TRUE(
        eventually([&] { return sat->events.count("start:guest." + name + ".transcript"); }));
    Json::Value t(Json::objectValue);
    t["text"] = text;
    t["confidence"] = 0.9;
    t["start"] = start_s;
    t["end"] = end_s;
    t["instance"] = name;
    EXPECT_TRUE(sat->on([&](Satellite& s) {
      return bool(s.publish(name + ".transcript", support::writeJson(t)));
    }));
  }
  size_t requests(const std::string& command) { return sat->events.count("req:" + command + ":"); }

  std::string name;
  std::unique_ptr<SatOnThread> sat;
};

class Agent : public ::testing::Test {
 protected:
  void start(const std::string& agent_config = "") {
    hub.modules = R"([{"name": "speech", "config": {"voice": "en"}},
        {"name": "nao-bridge", "config": {"backend": "simulated"}},
        {"name": "agent", "config": {"say": "speech.say", "expression": "",
            "faces": "guest.faces", "codes": "guest.codes", "greet_after_s": 5)" +
                  agent_config + "}}]";
    ASSERT_TRUE(hub.start()) << hub.hub->log();
    ASSERT_TRUE(hub.hub->waitLog("AGENT-RULES")) << hub.hub->log();
    viewer = hub.satellite("viewer");
    viewer->on([](Satellite& s) { s.subscribe("agent.dialogue"); });
    // "subscribed" says the SUBSCRIBE was sent: wait until the hub has it, so that no entry the
    // agent writes from now on can pass it.
    ASSERT_TRUE(eventually([&] {
      return viewer->on([](Satellite& s) {
        return s.syncClient().value()->channel("agent.dialogue").value().subscribers;
      }) == 1u;
    }));
  }
  // The dialogue entries so far.
  std::vector<Json::Value> dialogue() {
    std::vector<Json::Value> out;
    for (const auto& line : viewer->events.with("data:agent.dialogue:")) out.push_back(json(line));
    return out;
  }
  // Waits for the n-th dialogue entry (1-based) and returns it.
  Json::Value entry(size_t n) {
    EXPECT_TRUE(eventually([&] { return dialogue().size() >= n; })) << hub.hub->log();
    auto all = dialogue();
    return all.size() >= n ? all[n - 1] : Json::Value();
  }
  Json::Value command(const std::string& cmd, const Variant& value) {
    auto caller = hub.satellite("caller");
    auto r = caller->on([&](Satellite& s) { return s.call("agent.command", cmd, value); });
    EXPECT_TRUE(r) << (r ? "" : r.error().message);
    return r ? json(flow::variantToJsonText(*r)) : Json::Value();
  }
  void expectCleanStop() { EXPECT_EQ(hub.hub->stop(), 0) << hub.hub->log(); }

  NamedHub hub{"robot"};
  std::unique_ptr<SatOnThread> viewer;
};

TEST_F(Agent, HearsARecogniserAnswersActsAndPausesItWhileSpeaking) {
  start();
  Recogniser rec(hub, "rec1");
  // The rules' command grammar, handed over when the recogniser appeared.
  ASSERT_TRUE(eventually([&] { return rec.requests("set_grammar") == 1; })) << hub.hub->log();
  const Json::Value grammar = json(rec.sat->events.with("req:set_grammar:")[0]);
  EXPECT_NE(grammar["jsgf"].asString().find("stand up"), std::string::npos)
      << support::writeJson(grammar);

  auto nao = hub.satellite("nao");
  nao->on([](Satellite& s) { s.subscribe("nao-bridge.posture"); });
  rec.hear("Sit down!", 1.0, 1.6);
  Json::Value e = entry(1);
  EXPECT_EQ(e["heard"].asString(), "Sit down!");
  EXPECT_EQ(e["intent"].asString(), "sit");
  EXPECT_EQ(e["answer"].asString(), "Sitting down.");
  EXPECT_EQ(e["instance"].asString(), "guest.rec1");
  // The recogniser is paused while the avatar speaks, and resumed after.
  ASSERT_TRUE(eventually([&] { return rec.requests("pause") == 1; }));
  EXPECT_EQ(command("state", Variant::Map{})["speaking"].asBool(), true);
  rec.hear("stand up", 2.0, 2.5);  // the robot hearing itself: ignored
  ASSERT_TRUE(eventually([&] { return rec.requests("resume") == 1; }, 10000));
  EXPECT_EQ(command("state", Variant::Map{})["ignored_while_speaking"].asUInt64(), 1u);
  EXPECT_EQ(dialogue().size(), 1u);

  // The Nao sat down (the simulated robot's posture).
  EXPECT_TRUE(eventually([&] {
    for (const auto& p : nao->events.with("data:nao-bridge.posture:")) {
      if (json(p)["posture"].asString() == "Sit") return true;
    }
    return false;
  })) << hub.hub->log();

  // Not understood: the fallback.
  rec.hear("purple monkey dishwasher", 5.0, 6.0);
  e = entry(2);
  EXPECT_TRUE(e["intent"].isNull());
  EXPECT_EQ(e["answer"].asString(), "Sorry, I did not understand.");
  expectCleanStop();
}

TEST_F(Agent, TwoRecognisersHearingOneUtteranceAnswerOnce) {
  start(R"(, "barge_in": true)");
  Recogniser a(hub, "asr-a"), b(hub, "asr-b");
  a.hear("hello robot", 10.0, 10.8);
  ASSERT_EQ(entry(1)["intent"].asString(), "hello");
  // One that comes while the avatar speaks gets the grammar and is not paused either.
  Recogniser c(hub, "asr-c");
  ASSERT_TRUE(eventually([&] { return c.requests("set_grammar") == 1; }));
  EXPECT_TRUE(command("state", Variant::Map{})["speaking"].asBool());
  b.hear("hello robot", 10.05, 10.85);  // the same words at the same time: a duplicate
  b.hear("good morning", 12.0, 12.7);   // another utterance: answered
  EXPECT_EQ(entry(2)["heard"].asString(), "good morning");
  EXPECT_EQ(dialogue().size(), 2u);
  EXPECT_EQ(command("state", Variant::Map{})["duplicates"].asUInt64(), 1u);
  // With barge_in the recognisers keep listening while the avatar speaks.
  EXPECT_EQ(a.requests("pause") + b.requests("pause") + c.requests("pause"), 0u);
  expectCleanStop();
}

TEST_F(Agent, SlotsMemoryAndTheDatabase) {
  start();
  EXPECT_EQ(command("hear", Variant::Map{{"text", "my name is Ada"}})["answer"].asString(),
            "Nice to meet you, ada.");
  EXPECT_EQ(command("hear", Variant::Map{{"text", "what is my name"}})["answer"].asString(),
            "You told me your name is ada.");
  auto reader = hub.satellite("reader");
  auto memory = reader->on([](Satellite& s) { return s.get("memory.user_name", "agent"); });
  ASSERT_TRUE(memory) << memory.error().message;
  EXPECT_EQ(*memory, Variant("ada"));
  auto intent = reader->on([](Satellite& s) { return s.get("intent", "agent"); });
  ASSERT_TRUE(intent);
  EXPECT_EQ(*intent, Variant("who_am_i"));
  EXPECT_EQ(command("hear", Variant::Map{{"text", "count to twenty five"}})["answer"].asString(),
            "I can count to 25, but I will spare you.");
  expectCleanStop();
}

TEST_F(Agent, GreetsAFaceReadsACodeAndSaysWhatItSees) {
  start();
  auto camera = hub.satellite("camera");
  ASSERT_TRUE(camera->on([](Satellite& s) {
    return s.addChannel({.name = "faces", .mime = "application/json"}) &&
           s.addChannel({.name = "codes", .mime = "application/json"});
  }));
  ASSERT_TRUE(eventually([&] {
    return camera->events.count("start:guest.faces") && camera->events.count("start:guest.codes");
  }));
  auto publish = [&](const std::string& chan, const std::string& text) {
    ASSERT_TRUE(camera->on([&](Satellite& s) { return bool(s.publish(chan, text)); }));
  };
  const std::string face =
      R"({"width":640,"height":360,"faces":[{"x":251,"y":38,"w":77,"h":77,"score":0.8}]})";
  publish("faces", face);
  Json::Value e = entry(1);
  EXPECT_EQ(e["event"].asString(), "face_appeared");
  EXPECT_EQ(e["answer"].asString(), "Hello there!");
  publish("faces", face);  // still there: no second greeting
  const std::string code =
      R"({"width":640,"height":360,"codes":[{"type":"QR-Code","text":"hello world"}]})";
  publish("codes", code);
  e = entry(2);
  EXPECT_EQ(e["event"].asString(), "code_seen");
  EXPECT_EQ(e["answer"].asString(), "The code says hello world.");
  publish("codes", code);  // the same code again: not read twice
  publish("faces", face);
  EXPECT_EQ(command("hear", Variant::Map{{"text", "what do you see"}})["answer"].asString(),
            "I see one face and a code that says hello world.");
  // Its dialogue entry reaches the viewer on another connection than the answer: wait for it.
  EXPECT_EQ(entry(3)["heard"].asString(), "what do you see");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(dialogue().size(), 3u);  // no second greeting, no second reading
  expectCleanStop();
}

TEST_F(Agent, AWakePhraseFromItsRulesFile) {
  const fs::path rules = hub.dir.path() / "rules.json";
  std::ofstream(rules) << R"({"wake_phrase": "hey robot",
      "intents": [{"name": "stand", "phrases": ["stand up"], "actions": [{"say": "Standing."}]}],
      "events": {"woken": [{"say": "Yes?"}]}})";
  start(R"(, "rules": ")" + rules.string() + R"(", "awake_s": 30)");
  Json::Value e = command("hear", Variant::Map{{"text", "stand up"}});
  EXPECT_EQ(e["ignored"].asString(), "no wake phrase");
  EXPECT_FALSE(e.isMember("answer"));
  e = command("hear", Variant::Map{{"text", "Hey robot"}});
  EXPECT_EQ(e["answer"].asString(), "Yes?");
  e = command("hear", Variant::Map{{"text", "stand up"}});  // awake now
  EXPECT_EQ(e["answer"].asString(), "Standing.");
  e = command("hear", Variant::Map{{"text", "hey robot stand up"}});
  EXPECT_EQ(e["answer"].asString(), "Standing.");
  expectCleanStop();
}

TEST_F(Agent, ABadRulesFileIsReportedAndTheHubGoesOn) {
  const fs::path rules = hub.dir.path() / "bad-rules.json";
  std::ofstream(rules) << R"({"intents": [{"name": "x", "phrases": ["(stand up"],
      "actions": [{"say": "no"}]}]})";
  hub.modules = R"([{"name": "agent", "config": {"rules": ")" + rules.string() + R"("}}])";
  ASSERT_TRUE(hub.start()) << hub.hub->log();
  auto s = hub.satellite("probe");  // the hub is up and serves
  EXPECT_TRUE(hub.hub->waitLog("$.intents[0].phrases[0]: column 10: missing ')'"))
      << hub.hub->log();
  // Read after start (off the loop): the module fails then, by name, and is stopped.
  EXPECT_TRUE(hub.hub->waitLog("MODULE-FAILED module agent")) << hub.hub->log();
  EXPECT_TRUE(hub.hub->waitLog("MODULE-STOPPED module agent")) << hub.hub->log();
  expectCleanStop();
}

TEST_F(Agent, TheRulesFileIsReadOffTheLoop) {
  // A FIFO with no writer yet: opening it blocks until the test writes the rules. The hub
  // starts and serves meanwhile; a command waits for the rules and is answered by them.
  const fs::path rules = hub.dir.path() / "rules.fifo";
  ASSERT_EQ(mkfifo(rules.c_str(), 0600), 0);
  hub.modules = R"([{"name": "agent", "config": {"say": "", "expression": "", "rules": ")" +
                rules.string() + R"("}}])";
  ASSERT_TRUE(hub.start()) << hub.hub->log();
  auto probe = hub.satellite("probe");  // the hub serves while the agent reads
  ASSERT_TRUE(eventually([&] {
    return probe->on(
        [](Satellite& s) { return s.syncClient().value()->channel("agent.command").ok(); });
  })) << hub.hub->log();
  auto answer = std::async(std::launch::async, [&] {
    return command("hear", Variant::Map{{"text", "stand up"}});
  });
  EXPECT_EQ(answer.wait_for(std::chrono::milliseconds(300)), std::future_status::timeout);
  std::ofstream(rules) << R"({"intents": [{"name": "stand", "phrases": ["stand up"],
      "actions": [{"say": "Standing."}]}]})";
  EXPECT_EQ(answer.get()["answer"].asString(), "Standing.");
  EXPECT_TRUE(hub.hub->waitLog("AGENT-RULES 1 intents")) << hub.hub->log();
  expectCleanStop();
}

}  // namespace
}  // namespace skr::sat::test
