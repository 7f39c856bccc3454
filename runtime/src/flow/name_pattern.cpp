// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/name_pattern.h>

#include <cstddef>
#include <vector>

namespace skr::flow {

namespace {

bool separator(char c) noexcept {
  return c == '.' || c == '/';
}

bool forbidden(char c) noexcept {
  const auto u = static_cast<unsigned char>(c);
  return u < 0x20 || u == 0x7F || c == ' ' || c == '\\' || c == '"';
}

}  // namespace

bool validShortName(std::string_view name) noexcept {
  if (name.empty() || name.size() > 128 || name.front() == '.') return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    if (!ok) return false;
  }
  return true;
}

Result<NamePattern> NamePattern::parse(std::string_view text) {
  if (text.empty()) return makeError(Errc::invalid_argument, "empty pattern");
  NamePattern p;
  size_t stars = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (forbidden(c)) {
      return makeError(Errc::invalid_argument,
                       "character " + std::to_string(static_cast<unsigned char>(c)) +
                           " at offset " + std::to_string(i) + " cannot be in a channel name");
    }
    stars = c == '*' ? stars + 1 : 0;
    if (stars > 2) {
      return makeError(Errc::invalid_argument,
                       "'***' at offset " + std::to_string(i - 2) + ": use '*' or '**'");
    }
    if (c == '*' || c == '?') p.literal_ = false;
  }
  p.text_ = std::string(text);
  return p;
}

// Dynamic programming over (pattern position, name position): row[j] is true when the pattern
// read so far matches name[0, j). '**' and '*' may match the empty string.
bool NamePattern::matches(std::string_view name) const {
  if (literal_) return name == text_;
  const std::string_view pat = text_;
  const size_t n = name.size();
  std::vector<char> row(n + 1, 0);
  std::vector<char> next(n + 1, 0);
  row[0] = 1;
  for (size_t i = 0; i < pat.size(); ++i) {
    const char c = pat[i];
    if (c == '*') {
      const bool cross = i + 1 < pat.size() && pat[i + 1] == '*';
      // A star extends a match over any run it may cover: every byte for '**', non-separators
      // for '*'.
      next[0] = row[0];
      for (size_t j = 1; j <= n; ++j) {
        next[j] = row[j] || (next[j - 1] && (cross || !separator(name[j - 1])));
      }
      if (cross) ++i;
    } else {
      next[0] = 0;
      for (size_t j = 1; j <= n; ++j) {
        const char got = name[j - 1];
        next[j] = row[j - 1] && (c == '?' ? !separator(got) : c == got);
      }
    }
    row.swap(next);
  }
  return row[n] != 0;
}

Result<NameFilter> NameFilter::parse(const std::vector<std::string>& patterns) {
  NameFilter f;
  for (size_t i = 0; i < patterns.size(); ++i) {
    std::string_view text = patterns[i];
    const bool negated = !text.empty() && text.front() == '!';
    if (negated) text.remove_prefix(1);
    auto p = NamePattern::parse(text);
    if (!p) {
      return makeError(Errc::invalid_argument, "pattern " + std::to_string(i + 1) + " '" +
                                                   patterns[i] + "': " + p.error().message);
    }
    (negated ? f.exclude_ : f.include_).push_back(std::move(*p));
  }
  return f;
}

bool NameFilter::selects(std::string_view name) const {
  for (const auto& p : exclude_) {
    if (p.matches(name)) return false;
  }
  if (include_.empty()) return !exclude_.empty();
  for (const auto& p : include_) {
    if (p.matches(name)) return true;
  }
  return false;
}

}  // namespace skr::flow
