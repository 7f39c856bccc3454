// SPDX-License-Identifier: Apache-2.0
// Channel-name patterns: the one syntax for every place that selects channels by name (flowctl
// filters, permission rules, hub-link filters, NATS export and import). docs/flow-protocol.md,
// "Channel-name patterns", is the specification.
//
//   guest.camera        that name only
//   guest.*             every channel of user guest whose short name has no dot
//   guest.**            every channel of user guest
//   *.faces             the "faces" channel of every user
//   face-?etect.*       ? is one character within a part
//   arm/**              every channel of linked hub "arm"; a pattern without '/' matches local
//   names
//   **                  every channel, local or remote
//
// A name's parts are separated by '.' (and the hub prefix by '/'): '*' and '?' stay within a part,
// '**' crosses parts. Matching is on the whole name and case-sensitive.
#pragma once

#include <skrobot/result.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

// A channel's short name (the part after "<user>."): 1 to 128 of A-Z a-z 0-9 _ - . not starting
// with '.'. The one rule for the hub, the satellite library and modules.
[[nodiscard]] bool validShortName(std::string_view name) noexcept;

class NamePattern {
 public:
  // Refuses an empty pattern, characters that no channel name may hold (space, control bytes,
  // '\\', '"'), and more than two '*' in a row. Never throws on bad input.
  [[nodiscard]] static Result<NamePattern> parse(std::string_view text);

  // True when the whole of `name` matches. O(pattern x name) time, O(name) memory.
  [[nodiscard]] bool matches(std::string_view name) const;

  [[nodiscard]] const std::string& text() const noexcept { return text_; }
  // True when the pattern has no wildcard: it names one channel.
  [[nodiscard]] bool isLiteral() const noexcept { return literal_; }

 private:
  std::string text_;
  bool literal_ = true;
};

// An ordered set of patterns, some negated with a leading '!': a name is selected when it matches
// at least one plain pattern and no negated one ("camera.*", "!camera.debug"). An empty filter
// selects nothing; a filter of only negated patterns selects everything they do not exclude.
class NameFilter {
 public:
  NameFilter() = default;
  // Each entry is one pattern; the error names the entry that failed ("pattern 2 'a b': ...").
  [[nodiscard]] static Result<NameFilter> parse(const std::vector<std::string>& patterns);

  [[nodiscard]] bool selects(std::string_view name) const;
  [[nodiscard]] bool empty() const noexcept { return include_.empty() && exclude_.empty(); }

 private:
  std::vector<NamePattern> include_;
  std::vector<NamePattern> exclude_;
};

}  // namespace skr::flow
