// SPDX-License-Identifier: Apache-2.0
#include "rules.h"

#include "number_words.h"

#include <skrobot/support/json.hpp>

#include <algorithm>

namespace skr::agent {
namespace {

// Rules are a small file: shallow, a few hundred KB at most.
constexpr support::JsonLimits kRulesLimits{16, 1u << 20};

class Reader {
 public:
  explicit Reader(std::string origin) : origin_(std::move(origin)) {}

  Error fail(const std::string& path, const std::string& why) const {
    return makeError(Errc::invalid_argument, origin_ + ": " + path + ": " + why);
  }

  Result<void> actions(const Json::Value& list, const std::string& path) const {
    if (!list.isArray()) return fail(path, "must be an array of actions");
    for (Json::ArrayIndex i = 0; i < list.size(); ++i) {
      if (auto r = action(list[i], path + "[" + std::to_string(i) + "]"); !r) return r;
    }
    return {};
  }

 private:
  Result<void> action(const Json::Value& a, const std::string& path) const {
    if (!a.isObject() || a.size() != 1) {
      return fail(path,
                  "an action is an object with one key (say, expression, nao, call, "
                  "remember, db)");
    }
    const std::string kind = a.getMemberNames()[0];
    const Json::Value& v = a[kind];
    const std::string at = path + "." + kind;
    if (kind == "say") {
      if (!v.isString() || v.asString().empty()) return fail(at, "must be non-empty text");
    } else if (kind == "expression") {
      if (v.isString()) return {};
      if (!v.isObject() || !v["name"].isString()) {
        return fail(at, "must be a name or {\"name\", \"weight\", \"duration_ms\"}");
      }
    } else if (kind == "nao") {
      if (!v.isObject() || !v["command"].isString()) return fail(at, "needs \"command\"");
    } else if (kind == "call") {
      if (!v.isObject() || !v["channel"].isString() || !v["command"].isString()) {
        return fail(at, "needs \"channel\" and \"command\"");
      }
    } else if (kind == "remember") {
      if (!v.isObject() || v.empty()) return fail(at, "must be an object of keys and values");
    } else if (kind == "db") {
      if (!v.isObject() || !v["database"].isString() || !v["key"].isString() ||
          !v.isMember("value")) {
        return fail(at, "needs \"database\", \"key\" and \"value\"");
      }
    } else {
      return fail(path, "unknown action '" + kind + "' (say, expression, nao, call, remember, db)");
    }
    return {};
  }

  std::string origin_;
};

}  // namespace

Result<Rules> parseRules(const std::string& text, const std::string& origin) {
  const Reader in(origin);
  auto parsed = support::parseJson(text, kRulesLimits);
  if (!parsed) return makeError(Errc::invalid_argument, origin + ": " + parsed.error().message);
  const Json::Value& root = *parsed;
  if (!root.isObject()) return in.fail("$", "must be an object");
  for (const std::string& key : root.getMemberNames()) {
    if (key != "wake_phrase" && key != "intents" && key != "events" && key != "fallback") {
      return in.fail("$." + key, "unknown key (wake_phrase, intents, events, fallback)");
    }
  }
  Rules rules;
  if (root.isMember("wake_phrase")) {
    if (!root["wake_phrase"].isString()) return in.fail("$.wake_phrase", "must be text");
    rules.wake_phrase = wordsOf(root["wake_phrase"].asString());
  }
  const Json::Value& intents = root["intents"];
  if (!intents.isArray() || intents.empty()) {
    return in.fail("$.intents", "must be a non-empty array");
  }
  for (Json::ArrayIndex i = 0; i < intents.size(); ++i) {
    const std::string at = "$.intents[" + std::to_string(i) + "]";
    const Json::Value& e = intents[i];
    if (!e.isObject()) return in.fail(at, "must be an object");
    for (const std::string& key : e.getMemberNames()) {
      if (key != "name" && key != "phrases" && key != "actions") {
        return in.fail(at + "." + key, "unknown key (name, phrases, actions)");
      }
    }
    Intent intent;
    if (!e["name"].isString() || e["name"].asString().empty()) {
      return in.fail(at + ".name", "must be non-empty text");
    }
    intent.name = e["name"].asString();
    const Json::Value& phrases = e["phrases"];
    if (!phrases.isArray() || phrases.empty()) {
      return in.fail(at + ".phrases", "must be a non-empty array of patterns");
    }
    for (Json::ArrayIndex k = 0; k < phrases.size(); ++k) {
      const std::string pat = at + ".phrases[" + std::to_string(k) + "]";
      if (!phrases[k].isString()) return in.fail(pat, "must be text");
      auto p = PhrasePattern::parse(phrases[k].asString());
      if (!p) return in.fail(pat, p.error().message);
      intent.phrases.push_back(std::move(p).value());
    }
    if (auto r = in.actions(e["actions"], at + ".actions"); !r) return r.error();
    intent.actions = e["actions"];
    rules.intents.push_back(std::move(intent));
  }
  if (root.isMember("events")) {
    const Json::Value& events = root["events"];
    if (!events.isObject()) return in.fail("$.events", "must be an object");
    for (const std::string& name : events.getMemberNames()) {
      const std::string at = "$.events." + name;
      if (std::find_if(std::begin(kEvents), std::end(kEvents),
                       [&](const char* e) { return name == e; }) == std::end(kEvents)) {
        return in.fail(at, "unknown event (face_appeared, code_seen, woken)");
      }
      if (auto r = in.actions(events[name], at); !r) return r.error();
      rules.events[name] = events[name];
    }
  }
  if (root.isMember("fallback")) {
    if (auto r = in.actions(root["fallback"], "$.fallback"); !r) return r.error();
    rules.fallback = root["fallback"];
  }
  return rules;
}

std::optional<IntentMatch> Rules::match(const std::vector<std::string>& words) const {
  std::optional<IntentMatch> best;
  int best_score = -1;
  for (const Intent& intent : intents) {
    for (const PhrasePattern& p : intent.phrases) {
      if (p.literalWords() <= best_score) continue;
      if (auto slots = p.match(words)) {
        best = IntentMatch{&intent, std::move(*slots)};
        best_score = p.literalWords();
      }
    }
  }
  return best;
}

std::string Rules::grammar() const {
  std::string wake;
  for (const std::string& w : wake_phrase) wake += (wake.empty() ? "" : " ") + w;
  std::string alternatives;
  for (const Intent& intent : intents) {
    for (const PhrasePattern& p : intent.phrases) {
      if (auto g = p.jsgf()) alternatives += (alternatives.empty() ? "" : "\n  | ") + *g;
    }
  }
  std::string out = "#JSGF V1.0;\ngrammar agent;\n";
  out +=
      "public <command> = " + (wake.empty() ? "" : "[" + wake + "] ") + "(" + alternatives + ");\n";
  if (out.find("<number>") != std::string::npos) out += numberGrammar();
  return out;
}

std::string fillText(const std::string& text, const Vars& vars) {
  std::string out;
  size_t i = 0;
  while (i < text.size()) {
    const size_t open = text.find('{', i);
    const size_t close = open == std::string::npos ? open : text.find('}', open);
    if (close == std::string::npos) break;
    out.append(text, i, open - i);
    const auto it = vars.find(text.substr(open + 1, close - open - 1));
    if (it != vars.end()) out += it->second;
    i = close + 1;
  }
  out.append(text, std::min(i, text.size()), std::string::npos);
  return out;
}

Json::Value fillValue(const Json::Value& v, const Vars& vars,
                      const std::map<std::string, double>& numbers) {
  if (v.isString()) {
    const std::string s = v.asString();
    if (s.size() > 2 && s.front() == '{' && s.back() == '}' &&
        s.find('{', 1) == std::string::npos) {
      if (auto n = numbers.find(s.substr(1, s.size() - 2)); n != numbers.end()) {
        return Json::Value(n->second);
      }
    }
    return Json::Value(fillText(s, vars));
  }
  if (v.isArray() || v.isObject()) {
    Json::Value out = v;
    for (auto it = out.begin(); it != out.end(); ++it) *it = fillValue(*it, vars, numbers);
    return out;
  }
  return v;
}

}  // namespace skr::agent
