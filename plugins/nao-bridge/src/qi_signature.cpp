// SPDX-License-Identifier: Apache-2.0
#include "qi_signature.h"

#include <cctype>
#include <cstring>

namespace skr::nao::qi {
namespace {

constexpr const char* kBasic = "bcCwWiIlLfdsrmovX";

class Parser {
 public:
  explicit Parser(std::string_view s) : s_(s) {}

  Result<Type> type(int depth) {
    if (depth > kMaxSignatureDepth)
      return makeError(Errc::protocol_error, "signature nested too deeply");
    if (pos_ >= s_.size()) return makeError(Errc::protocol_error, "signature ends early");
    const char c = s_[pos_++];
    Type t;
    t.kind = c;
    if (c != '\0' && std::strchr(kBasic, c) != nullptr) return t;
    if (c == '[' || c == '{') {
      const char close = c == '[' ? ']' : '}';
      const std::size_t want = c == '[' ? 1 : 2;
      while (t.items.size() < want) {
        auto item = type(depth + 1);
        if (!item) return item.error();
        t.items.push_back(std::move(item.value()));
      }
      if (pos_ >= s_.size() || s_[pos_] != close) {
        return makeError(Errc::protocol_error, std::string("signature: expected '") + close + "'");
      }
      ++pos_;
      return t;
    }
    if (c == '(') {
      while (pos_ < s_.size() && s_[pos_] != ')') {
        auto item = type(depth + 1);
        if (!item) return item.error();
        t.items.push_back(std::move(item.value()));
      }
      if (pos_ >= s_.size()) return makeError(Errc::protocol_error, "signature: expected ')'");
      ++pos_;
      if (pos_ < s_.size() && s_[pos_] == '<') {
        auto r = annotation(t);
        if (!r) return r.error();
      }
      return t;
    }
    return makeError(Errc::protocol_error,
                     std::string("signature: unknown type '") +
                         (std::isprint(static_cast<unsigned char>(c)) ? c : '?') + "'");
  }

  [[nodiscard]] bool done() const { return pos_ == s_.size(); }

 private:
  // "<Name,field,...>": names are letters, digits and '_'.
  Result<void> annotation(Type& t) {
    ++pos_;
    std::vector<std::string> names(1);
    while (pos_ < s_.size() && s_[pos_] != '>') {
      const char c = s_[pos_++];
      if (c == ',') {
        names.emplace_back();
      } else if (std::isalnum(static_cast<unsigned char>(c)) || c == '_') {
        names.back() += c;
      } else {
        return makeError(Errc::protocol_error, "signature: bad character in annotation");
      }
    }
    if (pos_ >= s_.size()) return makeError(Errc::protocol_error, "signature: expected '>'");
    ++pos_;
    t.name = names.front();
    t.fields.assign(names.begin() + 1, names.end());
    return {};
  }

  std::string_view s_;
  std::size_t pos_ = 0;
};

}  // namespace

Result<Type> parseSignature(std::string_view sig) {
  if (sig.size() > kMaxSignatureBytes) return makeError(Errc::protocol_error, "signature too long");
  Parser p(sig);
  auto t = p.type(0);
  if (!t) return t;
  if (!p.done()) return makeError(Errc::protocol_error, "signature: trailing characters");
  return t;
}

std::string toString(const Type& t) {
  switch (t.kind) {
    case '[':
      return "[" + toString(t.items.at(0)) + "]";
    case '{':
      return "{" + toString(t.items.at(0)) + toString(t.items.at(1)) + "}";
    case '(': {
      std::string s = "(";
      for (const Type& i : t.items) s += toString(i);
      s += ")";
      if (!t.name.empty() || !t.fields.empty()) {
        s += "<" + t.name;
        for (const auto& f : t.fields) s += "," + f;
        s += ">";
      }
      return s;
    }
    default:
      return std::string(1, t.kind);
  }
}

std::size_t minWireSize(const Type& t) {
  switch (t.kind) {
    case 'b':
    case 'c':
    case 'C':
      return 1;
    case 'w':
    case 'W':
      return 2;
    case 'i':
    case 'I':
    case 'f':
    case 's':
    case 'r':
    case 'm':
    case '[':
    case '{':
      return 4;
    case 'l':
    case 'L':
    case 'd':
      return 8;
    case '(': {
      std::size_t n = 0;
      for (const Type& i : t.items) n += minWireSize(i);
      return n;
    }
    default:
      return 0;
  }
}

}  // namespace skr::nao::qi
