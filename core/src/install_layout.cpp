// SPDX-License-Identifier: Apache-2.0
#include <skrobot/hub/install_layout.h>

#include <cstdlib>
#include <system_error>

namespace skr {

namespace fs = std::filesystem;

fs::path executableDir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}

namespace {

fs::path besideExecutable(const char* relative) {
  const fs::path dir = executableDir();
  return dir.empty() ? fs::path() : (dir / relative).lexically_normal();
}

}  // namespace

fs::path installedModuleDir() {
  return besideExecutable(SKROBOT_REL_BIN_TO_MODULES);
}

fs::path installedDataDir() {
  return besideExecutable(SKROBOT_REL_BIN_TO_DATA);
}

fs::path defaultConfigFile() {
  if (const char* env = std::getenv("SKROBOT_CONFIG"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  if (const fs::path data = installedDataDir();
      !data.empty() && fs::is_regular_file(data / "default.json", ec)) {
    return data / "default.json";
  }
  return "config/default.json";
}

}  // namespace skr
