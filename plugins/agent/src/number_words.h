// SPDX-License-Identifier: Apache-2.0
// Numbers as recognisers write them: digits ("3", "2.5") or English words ("three",
// "twenty five", "a hundred and five"), for the agent's number slots.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace skr::agent {

// The value of words[0..n), all of them one number; nullopt when they are not exactly one.
[[nodiscard]] std::optional<double> numberFromWords(const std::vector<std::string>& words);

// Whether `word` can be part of a number (a digit string or a number word).
[[nodiscard]] bool isNumberWord(const std::string& word);

// The JSGF rules of the number words a grammar accepts (0 to 999), as "<number> = ...;" lines.
[[nodiscard]] std::string numberGrammar();

}  // namespace skr::agent
