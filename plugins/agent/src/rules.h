// SPDX-License-Identifier: Apache-2.0
// The agent's rules file (docs/agent.md): intents (phrase patterns and actions), what to do when
// a face appears or a code is seen, the fallback, and the wake phrase.
//
//   {"wake_phrase": "robot",
//    "intents": [{"name": "walk", "phrases": ["(walk | go) forward"],
//                 "actions": [{"nao": {"command": "walk", "value": {"x": 0.5}}},
//                             {"say": "Walking."}]}],
//    "events": {"face_appeared": [{"say": "Hello there!"}]},
//    "fallback": [{"say": "Sorry?"}]}
//
// An action is an object with one key: say (text), expression (name, or {name, weight,
// duration_ms}), nao ({command, value}), call ({channel, command, value}), remember ({key:
// value}: the agent's database), db ({database, key, value}). Text and string values are
// templates: {slot}, {heard}, {seen}, {code}, {time}, {memory.KEY}; a string that is exactly
// "{slot}" of a number slot becomes the number.
#pragma once

#include "phrase_pattern.h"

#include <json/value.h>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <skrobot/result.hpp>

namespace skr::agent {

struct Intent {
  std::string name;
  std::vector<PhrasePattern> phrases;
  Json::Value actions;  // an array of checked action objects
};

struct IntentMatch {
  const Intent* intent = nullptr;
  Slots slots;
};

// The events a rules file may answer.
inline constexpr const char* kEvents[] = {"face_appeared", "code_seen", "woken"};

struct Rules {
  std::vector<std::string> wake_phrase;  // words; empty: always listening
  std::vector<Intent> intents;
  std::map<std::string, Json::Value> events;
  Json::Value fallback{Json::arrayValue};

  // The most specific intent whose phrase matches all of `words` (most literal words; the first
  // in the file on a tie).
  [[nodiscard]] std::optional<IntentMatch> match(const std::vector<std::string>& words) const;
  // A JSGF grammar of every phrase a grammar can hold (those without free or word slots), the
  // wake phrase optional before each; what the agent hands the recognisers.
  [[nodiscard]] std::string grammar() const;
};

// Reads rules from JSON text; errors name `origin`, the JSON path and the reason:
// "rules.json: $.intents[2].phrases[0]: column 7: missing ')'".
[[nodiscard]] Result<Rules> parseRules(const std::string& text, const std::string& origin);

// Template filling: {name} from `vars` ("" when unknown).
using Vars = std::map<std::string, std::string>;
[[nodiscard]] std::string fillText(const std::string& text, const Vars& vars);
// A JSON value with every string filled; "{x}" alone becomes a number when `numbers` has x.
[[nodiscard]] Json::Value fillValue(const Json::Value& v, const Vars& vars,
                                    const std::map<std::string, double>& numbers);

}  // namespace skr::agent
