// SPDX-License-Identifier: Apache-2.0
#include "shared_library.h"

#include <dlfcn.h>

#include <string>
#include <utility>

namespace skr {

Result<SharedLibrary> SharedLibrary::open(const std::filesystem::path& file) {
  std::error_code ec;
  const auto absolute = std::filesystem::absolute(file, ec);
  const std::string name = (ec ? file : absolute).string();
  dlerror();  // clear a stale message
  void* handle = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    return makeError(Errc::io_error, why != nullptr ? why : "dlopen failed");
  }
  return SharedLibrary(handle);
}

SharedLibrary& SharedLibrary::operator=(SharedLibrary&& other) noexcept {
  if (this != &other) {
    close();
    handle_ = std::exchange(other.handle_, nullptr);
  }
  return *this;
}

void* SharedLibrary::symbol(const char* name) const noexcept {
  return handle_ != nullptr ? dlsym(handle_, name) : nullptr;
}

void SharedLibrary::close() noexcept {
  if (handle_ != nullptr) dlclose(std::exchange(handle_, nullptr));
}

}  // namespace skr
