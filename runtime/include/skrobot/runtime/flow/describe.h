// SPDX-License-Identifier: Apache-2.0
// A message's layout as the documentation writes it: its fields in wire order, each as
// "<wire type> <name>" ("u16 chan_id", "str16 name", "value props", "rest payload"); a list is
// "u32 count, count × <part>". Read from the
// struct's SKR_FLOW_FIELDS, so the text cannot drift from what the codec reads and writes. Used by
// tools/flow-catalogue (docs/flow-protocol.md's reference, the generated client tables) and tests.
#pragma once

#include <skrobot/runtime/flow/messages.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

struct FieldText {
  std::string type;  // u8 u16 u32 u64 str16 str32 value rest, a part's name, "list of <part>"
  std::string name;  // the member's name; empty for a part in place
  // "u16 chan_id"; a field named as its type ("value value") is just "value".
  [[nodiscard]] std::string text() const {
    return name.empty() || name == type ? type : type + " " + name;
  }
  bool operator==(const FieldText&) const = default;
};

namespace detail {

// Splits SKR_FLOW_FIELDS' "a, b, c".
inline std::vector<std::string> splitFieldNames(std::string_view names) {
  std::vector<std::string> out;
  while (!names.empty()) {
    const size_t comma = names.find(',');
    std::string_view one = names.substr(0, comma);
    while (!one.empty() && one.front() == ' ') one.remove_prefix(1);
    while (!one.empty() && one.back() == ' ') one.remove_suffix(1);
    out.emplace_back(one);
    if (comma == std::string_view::npos) break;
    names.remove_prefix(comma + 1);
  }
  return out;
}

class FieldDescriber {
 public:
  explicit FieldDescriber(std::string_view names) : names_(splitFieldNames(names)) {}

  bool operator()(uint8_t&) { return add("u8"); }
  bool operator()(uint16_t&) { return add("u16"); }
  bool operator()(uint32_t&) { return add("u32"); }
  bool operator()(uint64_t&) { return add("u64"); }
  bool operator()(std::string&) { return add("str16"); }
  bool operator()(msg::Text32&) { return add("str32"); }
  bool operator()(msg::Rest&) { return add("rest"); }
  bool operator()(Variant&) { return add("value"); }
  template <class T>
  requires requires { T::wire_name; }
  bool operator()(T&) {
    ++at_;  // a part in place is named by its type
    fields.push_back({std::string(T::wire_name), {}});
    return true;
  }
  template <class T>
  bool operator()(std::vector<T>&) {
    add("u32", "count");
    fields.push_back({"count × " + std::string(T::wire_name), {}});
    return true;
  }

  std::vector<FieldText> fields;

 private:
  bool add(std::string type, std::string name = {}) {
    if (name.empty() && at_ < names_.size()) name = names_[at_];
    ++at_;
    fields.push_back({std::move(type), std::move(name)});
    return true;
  }
  std::vector<std::string> names_;
  size_t at_ = 0;
};

}  // namespace detail

// The fields of message M (or of a part such as ChannelInfo), in wire order.
template <class M>
std::vector<FieldText> describeFields() {
  M m{};
  detail::FieldDescriber d(M::field_names);
  (void)m.io(d);
  return d.fields;
}

// The same, as the documentation writes a body: "u16 chan_id, rest payload"; "-" for none.
template <class M>
std::string describeBody() {
  std::string out;
  for (const auto& f : describeFields<M>()) {
    if (!out.empty()) out += ", ";
    out += f.text();
  }
  return out.empty() ? "-" : out;
}

}  // namespace skr::flow
