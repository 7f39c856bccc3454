// SPDX-License-Identifier: Apache-2.0
// The agent's phrase patterns, number words and rules file, without a hub.
#include "rules.h"
#include "number_words.h"
#include "phrase_pattern.h"

#include <gtest/gtest.h>

namespace skr::agent {
namespace {

std::optional<Slots> matchOf(const std::string& pattern, const std::string& text) {
  auto p = PhrasePattern::parse(pattern);
  EXPECT_TRUE(p) << pattern << ": " << (p ? "" : p.error().message);
  if (!p) return std::nullopt;
  return p->match(wordsOf(text));
}

std::string patternError(const std::string& pattern) {
  auto p = PhrasePattern::parse(pattern);
  EXPECT_FALSE(p) << pattern;
  return p ? "" : p.error().message;
}

TEST(AgentWords, TranscriptsAreLoweredAndStrippedOfPunctuation) {
  EXPECT_EQ(wordsOf("Hello, Robot!  What's up?"),
            (std::vector<std::string>{"hello", "robot", "what's", "up"}));
  EXPECT_EQ(wordsOf("go 2.5 meters."), (std::vector<std::string>{"go", "2.5", "meters"}));
  EXPECT_TRUE(wordsOf(" ... ").empty());
}

TEST(AgentWords, NumbersInDigitsAndWords) {
  auto n = [](const std::string& text) { return numberFromWords(wordsOf(text)); };
  EXPECT_EQ(n("7"), 7);
  EXPECT_EQ(n("2.5"), 2.5);
  EXPECT_EQ(n("zero"), 0);
  EXPECT_EQ(n("thirteen"), 13);
  EXPECT_EQ(n("twenty five"), 25);
  EXPECT_EQ(n("a hundred"), 100);
  EXPECT_EQ(n("one hundred and five"), 105);
  EXPECT_EQ(n("three hundred twenty one"), 321);
  EXPECT_EQ(n("two thousand three hundred"), 2300);
  EXPECT_EQ(n("three four"), std::nullopt);  // two numbers, not one
  EXPECT_EQ(n("five twenty"), std::nullopt);
  EXPECT_EQ(n("twenty hundred"), std::nullopt);
  EXPECT_EQ(n("and"), std::nullopt);
  EXPECT_EQ(n("meters"), std::nullopt);
}

TEST(AgentPatterns, WordsChoicesOptionalPartsAndSlots) {
  EXPECT_TRUE(matchOf("stand up", "Stand up."));
  EXPECT_FALSE(matchOf("stand up", "stand up now"));  // the whole utterance
  EXPECT_TRUE(matchOf("(walk | go) forward", "go forward"));
  EXPECT_FALSE(matchOf("(walk | go) forward", "run forward"));
  EXPECT_TRUE(matchOf("hello [robot]", "hello"));
  EXPECT_TRUE(matchOf("hello [robot]", "hello robot"));
  EXPECT_TRUE(matchOf("look [(left | right) [please]]", "look right please"));
  EXPECT_TRUE(matchOf("a | b c", "b c"));  // a top-level choice

  auto s = matchOf("my name is {name}", "My name is Ada Lovelace");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->at("name").text, "ada lovelace");
  EXPECT_FALSE(matchOf("my name is {name}", "my name is"));  // a slot takes a word at least

  s = matchOf("go forward {d:number} (meters | steps)", "go forward twenty five meters");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->at("d").number, 25);
  EXPECT_EQ(s->at("d").text, "twenty five");
  EXPECT_FALSE(matchOf("go forward {d:number} meters", "go forward far meters"));

  s = matchOf("turn {side:word} [now]", "turn left now");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->at("side").text, "left");
  EXPECT_FALSE(matchOf("turn {side:word}", "turn hard left"));
}

TEST(AgentPatterns, BadPatternsSayWhereAndWhy) {
  EXPECT_EQ(patternError("(walk | go forward"), "column 19: missing ')'");
  EXPECT_EQ(patternError("walk ) go"), "column 6: unbalanced ')'");
  EXPECT_EQ(patternError("say {Name}"),
            "column 5: a slot's name is lower case letters, digits and '_': 'Name'");
  EXPECT_EQ(patternError("go {d:float}"),
            "column 4: unknown slot type 'float' (number, word, or none for words)");
  EXPECT_EQ(patternError("go (a | )"), "column 9: an empty alternative");
  EXPECT_EQ(patternError("go {d"), "column 4: missing '}'");
  EXPECT_EQ(patternError("go; now"), "column 3: unexpected ';'");
  EXPECT_EQ(patternError("  "), "an empty pattern");
}

TEST(AgentPatterns, Grammar) {
  auto p = PhrasePattern::parse("(walk | go) forward [{d:number} meters]");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->jsgf(), "(walk | go) forward [<number> meters]");
  EXPECT_EQ(PhrasePattern::parse("my name is {name}")->jsgf(), std::nullopt);
}

const char* kRules = R"({
  "wake_phrase": "Hey Robot",
  "intents": [
    {"name": "stop", "phrases": ["stop {what}"], "actions": [{"say": "Stopping {what}."}]},
    {"name": "stop_walking", "phrases": ["stop walking"], "actions": [{"say": "Stopped."}]},
    {"name": "walk", "phrases": ["walk {d:number} meters"],
     "actions": [{"nao": {"command": "walk", "value": {"x": "{d}", "note": "{d} m"}}}]}
  ],
  "events": {"code_seen": [{"say": "The code says {code}."}]},
  "fallback": [{"say": "Sorry?"}]
})";

TEST(AgentRules, TheMostSpecificIntentWins) {
  auto rules = parseRules(kRules, "rules.json");
  ASSERT_TRUE(rules) << rules.error().message;
  EXPECT_EQ(rules->wake_phrase, (std::vector<std::string>{"hey", "robot"}));
  auto m = rules->match(wordsOf("stop walking"));
  ASSERT_TRUE(m);
  EXPECT_EQ(m->intent->name, "stop_walking");
  m = rules->match(wordsOf("stop the music"));
  ASSERT_TRUE(m);
  EXPECT_EQ(m->intent->name, "stop");
  EXPECT_FALSE(rules->match(wordsOf("dance")));
}

TEST(AgentRules, GrammarListsWhatAGrammarCanHold) {
  auto rules = parseRules(kRules, "rules.json");
  ASSERT_TRUE(rules);
  const std::string g = rules->grammar();
  EXPECT_NE(g.find("#JSGF V1.0;"), std::string::npos);
  EXPECT_NE(g.find("public <command> = [hey robot] (stop walking\n  | walk <number> meters);"),
            std::string::npos)
      << g;
  EXPECT_NE(g.find("<number> = "), std::string::npos);
  EXPECT_EQ(g.find("{what}"), std::string::npos);
}

TEST(AgentRules, TemplatesFillTextAndNumbers) {
  const Vars vars{{"d", "3"}, {"name", "Ada"}};
  EXPECT_EQ(fillText("Hello {name}, {d} m{unknown}.", vars), "Hello Ada, 3 m.");
  EXPECT_EQ(fillText("no braces", vars), "no braces");
  EXPECT_EQ(fillText("open { brace", vars), "open { brace");
  Json::Value v(Json::objectValue);
  v["x"] = "{d}";
  v["note"] = "{d} m";
  v["list"].append("{name}");
  const Json::Value out = fillValue(v, vars, {{"d", 3.0}});
  EXPECT_TRUE(out["x"].isDouble());
  EXPECT_EQ(out["x"].asDouble(), 3.0);
  EXPECT_EQ(out["note"].asString(), "3 m");
  EXPECT_EQ(out["list"][0].asString(), "Ada");
}

TEST(AgentRules, BadRulesNameTheFileThePathAndTheReason) {
  auto error = [](const std::string& text) {
    auto r = parseRules(text, "my-rules.json");
    EXPECT_FALSE(r) << text;
    return r ? std::string() : r.error().message;
  };
  EXPECT_EQ(error(R"({"intents": [{"name": "a", "phrases": ["(x"], "actions": []}]})"),
            "my-rules.json: $.intents[0].phrases[0]: column 3: missing ')'");
  EXPECT_EQ(error(R"({"intents": [{"name": "a", "phrases": ["x"], "actions": [{"dance": 1}]}]})"),
            "my-rules.json: $.intents[0].actions[0]: unknown action 'dance' (say, expression, "
            "nao, call, remember, db)");
  EXPECT_EQ(error(R"({"intents": [{"name": "a", "phrases": ["x"], "actions": [{"say": ""}]}]})"),
            "my-rules.json: $.intents[0].actions[0].say: must be non-empty text");
  EXPECT_EQ(
      error(
          R"({"intents": [{"name": "a", "phrases": ["x"], "actions": [{"call": {"channel": "x"}}]}]})"),
      "my-rules.json: $.intents[0].actions[0].call: needs \"channel\" and \"command\"");
  EXPECT_EQ(error(R"({"intents": []})"), "my-rules.json: $.intents: must be a non-empty array");
  EXPECT_EQ(error(R"({"intents": [{"name": "a", "phrases": ["x"], "actions": []}], "colour": 1})"),
            "my-rules.json: $.colour: unknown key (wake_phrase, intents, events, fallback)");
  EXPECT_EQ(error(R"({"intents": [{"name": "a", "phrases": ["x"], "actions": []}],
                      "events": {"sneeze": []}})"),
            "my-rules.json: $.events.sneeze: unknown event (face_appeared, code_seen, woken)");
  EXPECT_NE(error("{\"intents\": ").find("my-rules.json: "), std::string::npos);
}

}  // namespace
}  // namespace skr::agent

namespace skr::agent {
namespace {

// Many slots over a long utterance would backtrack for ever: matching gives up, quickly.
TEST(AgentPatterns, BacktrackingIsBounded) {
  auto p = PhrasePattern::parse("{a} {b} {c} {d} {e} {f} {g} {h} zebra");
  ASSERT_TRUE(p);
  std::string text;
  for (int i = 0; i < 60; ++i) text += "word ";
  EXPECT_FALSE(p->match(wordsOf(text)));
  EXPECT_TRUE(p->match(wordsOf("a b c d e f g h zebra")));
}

}  // namespace
}  // namespace skr::agent
