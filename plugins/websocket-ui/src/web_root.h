// SPDX-License-Identifier: Apache-2.0
// The directory of the avatar page when the config names none: installed beside the module
// (<prefix>/share/skrobot/web, found from the module's own file) or a build tree's copy.
#pragma once

#include <string>

namespace skr::wsui {

// The first of <module dir>/SKROBOT_REL_MODULES_TO_WEB and <module dir>/../web that holds an
// index.html; the installed one when neither does (the server then reports it by name).
[[nodiscard]] std::string defaultWebRoot();

}  // namespace skr::wsui
