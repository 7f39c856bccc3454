// SPDX-License-Identifier: Apache-2.0
// qi type signatures ("s", "[f]", "{sm}", "(ss)<Name,a,b>"), parsed into a tree.
// Grammar (qiloop notes): basic b c C w W i I l L f d s r m o v X; list "[T]"; map "{KV}";
// tuple "(T...)" with an optional annotation "<Name,field,...>".
#pragma once

#include <skrobot/result.hpp>

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace skr::nao::qi {

constexpr std::size_t kMaxSignatureBytes = 4096;
constexpr int kMaxSignatureDepth = 16;

struct Type {
  char kind = 'v';          // a basic letter, or '[', '{', '('
  std::vector<Type> items;  // list: 1 element type; map: key, value; tuple: members
  std::string name;         // tuple annotation: struct name (may be empty)
  std::vector<std::string> fields;

  [[nodiscard]] bool operator==(const Type& o) const {
    return kind == o.kind && items == o.items;  // annotations do not change the wire format
  }
};

// The whole string must be exactly one type.
[[nodiscard]] Result<Type> parseSignature(std::string_view sig);
// The canonical text, with annotations.
[[nodiscard]] std::string toString(const Type& t);
// The fewest bytes a value of this type takes on the wire (0 for void and empty tuples).
[[nodiscard]] std::size_t minWireSize(const Type& t);

}  // namespace skr::nao::qi
