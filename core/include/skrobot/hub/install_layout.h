// SPDX-License-Identifier: Apache-2.0
// Where an installed hub finds its own files: relative to the directory of its executable, so
// that an install under any prefix works (docs/install.md). In a build tree these directories do
// not exist and the callers fall back to the build tree's own places.
#pragma once

#include <filesystem>

namespace skr {

// The directory of the running executable (/proc/self/exe); empty if it cannot be read.
[[nodiscard]] std::filesystem::path executableDir();
// <prefix>/<libdir>/skrobot/modules: the modules installed with the hub.
[[nodiscard]] std::filesystem::path installedModuleDir();
// <prefix>/share/skrobot: the default config (default.json) and the web page (web/).
[[nodiscard]] std::filesystem::path installedDataDir();

// The config the hub and `skrobot user` use without --config: $SKROBOT_CONFIG; else the one
// installed with the hub (<prefix>/share/skrobot/default.json) if it exists; else
// config/default.json of the current directory (a source checkout).
[[nodiscard]] std::filesystem::path defaultConfigFile();

}  // namespace skr
