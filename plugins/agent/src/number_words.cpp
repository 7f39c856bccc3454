// SPDX-License-Identifier: Apache-2.0
#include "number_words.h"

#include <charconv>
#include <map>

namespace skr::agent {
namespace {

const std::map<std::string, int, std::less<>>& units() {
  static const std::map<std::string, int, std::less<>> m{
      {"zero", 0},     {"one", 1},      {"two", 2},        {"three", 3},     {"four", 4},
      {"five", 5},     {"six", 6},      {"seven", 7},      {"eight", 8},     {"nine", 9},
      {"ten", 10},     {"eleven", 11},  {"twelve", 12},    {"thirteen", 13}, {"fourteen", 14},
      {"fifteen", 15}, {"sixteen", 16}, {"seventeen", 17}, {"eighteen", 18}, {"nineteen", 19}};
  return m;
}

const std::map<std::string, int, std::less<>>& tens() {
  static const std::map<std::string, int, std::less<>> m{
      {"twenty", 20}, {"thirty", 30},  {"forty", 40},  {"fifty", 50},
      {"sixty", 60},  {"seventy", 70}, {"eighty", 80}, {"ninety", 90}};
  return m;
}

std::optional<double> digits(const std::string& w) {
  double v = 0;
  const auto r = std::from_chars(w.data(), w.data() + w.size(), v);
  if (r.ec != std::errc() || r.ptr != w.data() + w.size()) return std::nullopt;
  return v;
}

}  // namespace

bool isNumberWord(const std::string& word) {
  return units().count(word) != 0 || tens().count(word) != 0 || word == "hundred" ||
         word == "thousand" || word == "and" || word == "a" || digits(word).has_value();
}

// A small grammar: [a|one..nine hundred [and]] [tens] [units], thousands as a multiplier.
std::optional<double> numberFromWords(const std::vector<std::string>& words) {
  if (words.empty()) return std::nullopt;
  if (words.size() == 1) {
    if (auto d = digits(words[0])) return d;
  }
  long total = 0;    // completed thousands
  long current = 0;  // below a thousand
  bool any = false, last_tens = false, last_unit = false;
  for (size_t i = 0; i < words.size(); ++i) {
    const std::string& w = words[i];
    if (auto u = units().find(w); u != units().end()) {
      if (last_unit || (last_tens && u->second >= 10)) return std::nullopt;  // "three four"
      current += u->second;
      last_unit = true;
      any = true;
    } else if (auto t = tens().find(w); t != tens().end()) {
      if (last_tens || last_unit) return std::nullopt;
      current += t->second;
      last_tens = true;
      any = true;
    } else if (w == "a" && i + 1 < words.size() &&
               (words[i + 1] == "hundred" || words[i + 1] == "thousand")) {
      current += 1;
      last_unit = true;
    } else if (w == "hundred") {
      if (!last_unit || current % 100 == 0 || current > 9) return std::nullopt;
      current *= 100;
      last_unit = last_tens = false;
      any = true;
    } else if (w == "thousand") {
      if (current == 0 || total != 0) return std::nullopt;
      total = current * 1000;
      current = 0;
      last_unit = last_tens = false;
      any = true;
    } else if (w == "and") {
      if (i == 0 || i + 1 == words.size() || (current % 100 != 0 && total == 0)) {
        return std::nullopt;
      }
    } else {
      return std::nullopt;
    }
  }
  if (!any) return std::nullopt;
  return static_cast<double>(total + current);
}

std::string numberGrammar() {
  std::string unit, teen, ten;
  auto add = [](std::string& list, const std::string& word) {
    list += (list.empty() ? "" : " | ") + word;
  };
  for (const auto& [word, value] : units()) {
    if (value > 0) add(value < 10 ? unit : teen, word);
  }
  for (const auto& [word, value] : tens()) add(ten, word);
  return "<unit> = " + unit + ";\n<teen> = " + teen + ";\n<tens> = " + ten +
         ";\n<below_hundred> = zero | <unit> | <teen> | <tens> [<unit>];\n"
         "<number> = <below_hundred> | (<unit> | a) hundred [[and] <below_hundred>];\n";
}

}  // namespace skr::agent
