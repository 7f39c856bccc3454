// SPDX-License-Identifier: Apache-2.0
#include "phrase_pattern.h"

#include "number_words.h"

#include <cctype>
#include <functional>

namespace skr::agent {

struct PhrasePattern::Node {
  enum class Kind { word, sequence, choice, optional, slot } kind = Kind::sequence;
  enum class Slot { words, word, number } slot = Slot::words;
  std::string text;         // a word, or a slot's name
  std::vector<Node> items;  // a sequence's parts; a choice's or an optional's alternatives
};

namespace {

using Node = PhrasePattern::Node;
constexpr size_t kMaxSlotWords = 8;

bool wordChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '\'' || c == '-' ||
         static_cast<unsigned char>(c) >= 0x80;
}

class Parser {
 public:
  explicit Parser(const std::string& text) : s_(text) {}

  Result<Node> pattern() {
    Node root = alternatives('\0');
    if (!error_.empty()) return fail();
    if (root.items.size() != 1) {  // a top-level '|' means a choice
      Node seq;
      seq.items.push_back(std::move(root));
      return seq;
    }
    return std::move(root.items[0]);
  }

 private:
  Result<Node> fail() {
    return makeError(Errc::invalid_argument, "column " + std::to_string(at_ + 1) + ": " + error_);
  }
  void error(const std::string& why) {
    if (error_.empty()) error_ = why;
  }

  // Sequences separated by '|' up to `close` ('\0' for the end); a choice node.
  Node alternatives(char close) {
    Node choice;
    choice.kind = Node::Kind::choice;
    for (;;) {
      choice.items.push_back(sequence());
      if (!error_.empty()) return choice;
      if (choice.items.back().items.empty() && close != ']' && i_ < s_.size()) {
        at_ = i_;
        error("an empty alternative");
        return choice;
      }
      if (i_ < s_.size() && s_[i_] == '|') {
        ++i_;
        continue;
      }
      if (close == '\0') {
        if (i_ < s_.size()) at_ = i_, error(std::string("unbalanced '") + s_[i_] + "'");
      } else if (i_ >= s_.size() || s_[i_] != close) {
        error(std::string("missing '") + close + "'");
      } else {
        ++i_;
      }
      return choice;
    }
  }

  Node sequence() {
    Node seq;
    for (;;) {
      while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
      at_ = i_;
      if (i_ >= s_.size() || s_[i_] == '|' || s_[i_] == ')' || s_[i_] == ']') return seq;
      const char c = s_[i_];
      if (c == '(' || c == '[') {
        ++i_;
        Node group = alternatives(c == '(' ? ')' : ']');
        if (c == '[') group.kind = Node::Kind::optional;
        seq.items.push_back(std::move(group));
      } else if (c == '{') {
        seq.items.push_back(slot());
      } else if (wordChar(c)) {
        Node w;
        w.kind = Node::Kind::word;
        while (i_ < s_.size() && wordChar(s_[i_])) {
          w.text += static_cast<char>(std::tolower(static_cast<unsigned char>(s_[i_++])));
        }
        seq.items.push_back(std::move(w));
      } else {
        error(std::string("unexpected '") + c + "'");
      }
      if (!error_.empty()) return seq;
    }
  }

  Node slot() {
    Node n;
    n.kind = Node::Kind::slot;
    const size_t end = s_.find('}', i_);
    if (end == std::string::npos) {
      error("missing '}'");
      return n;
    }
    std::string body = s_.substr(i_ + 1, end - i_ - 1);
    i_ = end + 1;
    std::string type;
    if (const size_t colon = body.find(':'); colon != std::string::npos) {
      type = body.substr(colon + 1);
      body.resize(colon);
    }
    n.text = body;
    if (body.empty() ||
        body.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos) {
      error("a slot's name is lower case letters, digits and '_': '" + body + "'");
    } else if (type == "number") {
      n.slot = Node::Slot::number;
    } else if (type == "word") {
      n.slot = Node::Slot::word;
    } else if (!type.empty()) {
      error("unknown slot type '" + type + "' (number, word, or none for words)");
    }
    return n;
  }

  const std::string& s_;
  size_t i_ = 0, at_ = 0;
  std::string error_;
};

int countLiteralWords(const Node& n) {
  if (n.kind == Node::Kind::word) return 1;
  if (n.kind == Node::Kind::sequence) {
    int sum = 0;
    for (const Node& c : n.items) sum += countLiteralWords(c);
    return sum;
  }
  return 0;  // alternatives and optional parts may be absent
}

using Next = std::function<bool(size_t)>;

class Matcher {
 public:
  Matcher(const std::vector<std::string>& words, Slots& slots) : w_(words), slots_(slots) {}

  bool node(const Node& n, size_t pos, const Next& next) {
    // Slots backtrack: a pattern of many slots over a long utterance could try a great many
    // splits. Past this many steps the utterance does not match.
    if (++steps_ > kMaxSteps) return false;
    switch (n.kind) {
      case Node::Kind::word:
        return pos < w_.size() && w_[pos] == n.text && next(pos + 1);
      case Node::Kind::sequence:
        return sequence(n.items, 0, pos, next);
      case Node::Kind::choice:
      case Node::Kind::optional:
        for (const Node& alt : n.items) {
          if (node(alt, pos, next)) return true;
        }
        return n.kind == Node::Kind::optional && next(pos);
      case Node::Kind::slot:
        return slot(n, pos, next);
    }
    return false;
  }

 private:
  bool sequence(const std::vector<Node>& items, size_t i, size_t pos, const Next& next) {
    if (i == items.size()) return next(pos);
    return node(items[i], pos, [&](size_t p) { return sequence(items, i + 1, p, next); });
  }

  bool slot(const Node& n, size_t pos, const Next& next) {
    const size_t most = n.slot == Node::Slot::word ? 1 : kMaxSlotWords;
    for (size_t len = 1; len <= most && pos + len <= w_.size(); ++len) {
      const std::vector<std::string> taken(w_.begin() + static_cast<long>(pos),
                                           w_.begin() + static_cast<long>(pos + len));
      SlotValue v;
      if (n.slot == Node::Slot::number) {
        if (!isNumberWord(taken.back())) break;
        v.number = numberFromWords(taken);
        if (!v.number) continue;
      }
      for (const std::string& word : taken) v.text += (v.text.empty() ? "" : " ") + word;
      slots_[n.text] = std::move(v);
      if (next(pos + len)) return true;
      slots_.erase(n.text);
    }
    return false;
  }

  static constexpr size_t kMaxSteps = 100'000;
  const std::vector<std::string>& w_;
  Slots& slots_;
  size_t steps_ = 0;
};

std::optional<std::string> jsgfOf(const Node& n) {
  switch (n.kind) {
    case Node::Kind::word:
      return n.text;
    case Node::Kind::slot:
      if (n.slot == Node::Slot::number) return std::string("<number>");
      return std::nullopt;
    case Node::Kind::sequence: {
      std::string out;
      for (const Node& c : n.items) {
        auto part = jsgfOf(c);
        if (!part) return std::nullopt;
        if (!part->empty()) out += (out.empty() ? "" : " ") + *part;
      }
      return out;
    }
    case Node::Kind::choice:
    case Node::Kind::optional: {
      std::string out;
      for (const Node& alt : n.items) {
        auto part = jsgfOf(alt);
        if (!part) return std::nullopt;
        if (part->empty()) continue;  // "[a |]": an empty alternative is what [] says
        out += (out.empty() ? "" : " | ") + *part;
      }
      if (out.empty()) return std::string();
      return n.kind == Node::Kind::optional ? "[" + out + "]" : "(" + out + ")";
    }
  }
  return std::nullopt;
}

}  // namespace

std::vector<std::string> wordsOf(const std::string& text) {
  std::vector<std::string> out;
  std::string word;
  for (size_t i = 0; i <= text.size(); ++i) {
    const char c = i < text.size() ? text[i] : ' ';
    const bool in_number =
        c == '.' && !word.empty() && std::isdigit(static_cast<unsigned char>(word.back())) &&
        i + 1 < text.size() && std::isdigit(static_cast<unsigned char>(text[i + 1]));
    if (wordChar(c) || in_number) {
      word += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!word.empty()) {
      out.push_back(std::move(word));
      word.clear();
    }
  }
  return out;
}

Result<PhrasePattern> PhrasePattern::parse(const std::string& text) {
  Result<Node> root = Parser(text).pattern();
  if (!root) return root.error();
  if (root->items.empty()) return makeError(Errc::invalid_argument, "an empty pattern");
  PhrasePattern p;
  p.text_ = text;
  p.literal_words_ = countLiteralWords(*root);
  p.root_ = std::make_shared<const Node>(std::move(root).value());
  return p;
}

std::optional<Slots> PhrasePattern::match(const std::vector<std::string>& words) const {
  Slots slots;
  Matcher m(words, slots);
  if (!m.node(*root_, 0, [&](size_t pos) { return pos == words.size(); })) return std::nullopt;
  return slots;
}

std::optional<std::string> PhrasePattern::jsgf() const {
  return jsgfOf(*root_);
}

}  // namespace skr::agent
