// SPDX-License-Identifier: Apache-2.0
#include "subject_map.h"

#include <cstddef>

namespace skr::nats_bridge {
namespace {

constexpr char kHex[] = "0123456789ABCDEF";

bool plainTokenByte(char c) noexcept {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' ||
         c == '_';
}

void escape(std::string& out, char esc, char c) {
  const auto u = static_cast<unsigned char>(c);
  out += esc;
  out += kHex[u >> 4];
  out += kHex[u & 15];
}

int hexValue(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;  // lower case is not written, so not read: one spelling per name
}

// Reads the escapes of `text` (esc followed by two upper-case hex digits); nullopt when one is
// malformed or stands for a byte that needed no escape (`plain`), so that a name has one
// spelling only.
template <class Plain>
std::optional<std::string> unescape(std::string_view text, char esc, Plain plain) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != esc) {
      out += text[i];
      continue;
    }
    if (i + 2 >= text.size()) return std::nullopt;
    const int hi = hexValue(text[i + 1]);
    const int lo = hexValue(text[i + 2]);
    if (hi < 0 || lo < 0) return std::nullopt;
    const char c = static_cast<char>(hi * 16 + lo);
    if (plain(c, out.empty())) return std::nullopt;
    out += c;
    i += 2;
  }
  return out;
}

}  // namespace

std::string encodeToken(std::string_view part, bool first) {
  if (part.empty()) return "%";
  std::string out;
  out.reserve(part.size());
  for (size_t i = 0; i < part.size(); ++i) {
    const char c = part[i];
    if (plainTokenByte(c) && !(first && i == 0 && c == '_')) {
      out += c;
    } else {
      escape(out, '%', c);
    }
  }
  return out;
}

std::string channelSubject(std::string_view prefix, std::string_view name) {
  std::string out(prefix);
  size_t start = 0;
  bool first = true;
  for (;;) {
    const size_t dot = name.find('.', start);
    const std::string_view part =
        name.substr(start, dot == std::string_view::npos ? std::string_view::npos : dot - start);
    out += '.';
    out += encodeToken(part, first);
    first = false;
    if (dot == std::string_view::npos) break;
    start = dot + 1;
  }
  return out;
}

std::optional<std::string> subjectChannel(std::string_view prefix, std::string_view subject) {
  if (subject.size() <= prefix.size() + 1 || subject.substr(0, prefix.size()) != prefix ||
      subject[prefix.size()] != '.') {
    return std::nullopt;
  }
  std::string_view rest = subject.substr(prefix.size() + 1);
  std::string name;
  bool first = true;
  for (;;) {
    const size_t dot = rest.find('.');
    const std::string_view token = rest.substr(0, dot);
    if (!first) name += '.';
    if (token != "%") {
      if (token.empty()) return std::nullopt;
      if (first && token[0] == '_') return std::nullopt;  // the bridge's own subjects
      const bool at_start = first;
      auto part = unescape(token, '%', [at_start](char c, bool start) {
        return plainTokenByte(c) && !(at_start && start && c == '_');
      });
      // One spelling per name: what needed no escape has none, what needed one has it.
      if (!part || part->empty() || encodeToken(*part, at_start) != token) return std::nullopt;
      name += *part;
    }
    first = false;
    if (dot == std::string_view::npos) break;
    rest = rest.substr(dot + 1);
  }
  return name;
}

std::string encodeKey(std::string_view key) {
  std::string out;
  out.reserve(key.size());
  for (size_t i = 0; i < key.size(); ++i) {
    const char c = key[i];
    const bool edge_dot = c == '.' && (i == 0 || i + 1 == key.size());
    if ((plainTokenByte(c) || c == '/' || c == '.') && !edge_dot) {
      out += c;
    } else {
      escape(out, '=', c);
    }
  }
  return out;
}

std::optional<std::string> decodeKey(std::string_view encoded) {
  if (encoded.empty()) return std::string();
  auto key = unescape(encoded, '=', [](char c, bool) {
    return plainTokenByte(c) || c == '/';  // a '.' may be escaped (at an edge): checked below
  });
  if (!key) return std::nullopt;
  if (encodeKey(*key) != encoded) return std::nullopt;  // one spelling per key
  return key;
}

std::optional<std::string> badSubject(std::string_view subject, bool wildcards) {
  if (subject.empty()) return "empty";
  size_t start = 0;
  for (;;) {
    const size_t dot = subject.find('.', start);
    const std::string_view token = subject.substr(start, dot - start);
    if (token.empty()) return "an empty token";
    for (char c : token) {
      const auto u = static_cast<unsigned char>(c);
      if (u <= 0x20 || u >= 0x7F) return "a space, control or non-ASCII byte";
    }
    const bool wild = token.find_first_of("*>") != std::string_view::npos;
    if (wild) {
      if (!wildcards) return "a wildcard ('*' or '>')";
      if (token != "*" && token != ">") return "'*' or '>' inside a token";
      if (token == ">" && dot != std::string_view::npos) return "'>' before the last token";
    }
    if (dot == std::string_view::npos) return std::nullopt;
    start = dot + 1;
  }
}

}  // namespace skr::nats_bridge
