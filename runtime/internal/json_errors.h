// SPDX-License-Identifier: Apache-2.0
// jsoncpp reports parse errors as "* Line 1, Column 8\n  Duplicate key: 'a'\n"; messages here
// are one line: "Line 1, Column 8: Duplicate key: 'a'". Internal.
#pragma once

#include <string>
#include <string_view>

namespace skr::flow {

inline std::string jsonErrorsOneLine(const std::string& errors) {
  std::string out;
  size_t i = 0;
  while (i < errors.size()) {
    size_t end = errors.find('\n', i);
    if (end == std::string::npos) end = errors.size();
    std::string_view line(errors.data() + i, end - i);
    while (!line.empty() && (line.front() == ' ' || line.front() == '*')) line.remove_prefix(1);
    if (!line.empty()) {
      if (!out.empty()) out += line.starts_with("Line ") ? "; " : ": ";
      out += line;
    }
    i = end + 1;
  }
  return out;
}

}  // namespace skr::flow
