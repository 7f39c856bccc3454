// SPDX-License-Identifier: Apache-2.0
// Run-time changes written back into the config file's text (flowctl module config --save;
// docs/robot.md): only the values changed are edited, so the rest of the file (comments, order,
// spacing, other modules, satellites) stays byte for byte as it was.
#pragma once

#include <skrobot/runtime/result.h>

#include <json/value.h>

#include <cstddef>
#include <string>
#include <string_view>

namespace skr {

// `text` with the keys of `values` (an object) set in the `config` object of the entry at
// `index` of the document's "modules": an existing value is replaced, a missing key is added at
// the start of that object, and a missing `config` object is added to the entry. config_error
// when the text is not a config with such an entry.
[[nodiscard]] Result<std::string> editModuleConfig(std::string_view text, std::size_t index,
                                                   const Json::Value& values);

}  // namespace skr
