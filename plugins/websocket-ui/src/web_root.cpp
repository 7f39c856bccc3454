// SPDX-License-Identifier: Apache-2.0
#include "web_root.h"

#include <dlfcn.h>

#include <filesystem>
#include <system_error>

namespace skr::wsui {

namespace fs = std::filesystem;

std::string defaultWebRoot() {
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&defaultWebRoot), &info) == 0 || info.dli_fname == nullptr) {
    return {};
  }
  std::error_code ec;
  const fs::path module_dir = fs::absolute(info.dli_fname, ec).parent_path();
  const fs::path installed = (module_dir / SKROBOT_REL_MODULES_TO_WEB).lexically_normal();
  for (const fs::path& dir : {installed, (module_dir / ".." / "web").lexically_normal()}) {
    if (fs::is_regular_file(dir / "index.html", ec)) return dir.string();
  }
  return installed.string();
}

}  // namespace skr::wsui
