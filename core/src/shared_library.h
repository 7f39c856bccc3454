// SPDX-License-Identifier: Apache-2.0
// RAII handle of a shared object opened with dlopen(RTLD_NOW | RTLD_LOCAL). Internal to the core.
#pragma once

#include <skrobot/runtime/result.h>

#include <filesystem>

namespace skr {

class SharedLibrary {
 public:
  SharedLibrary() noexcept = default;
  // Opens `file` (made absolute so that dlopen never searches LD_LIBRARY_PATH). The error
  // (Errc::io_error) carries dlerror()'s text.
  [[nodiscard]] static Result<SharedLibrary> open(const std::filesystem::path& file);

  ~SharedLibrary() { close(); }
  SharedLibrary(const SharedLibrary&) = delete;
  SharedLibrary& operator=(const SharedLibrary&) = delete;
  SharedLibrary(SharedLibrary&& other) noexcept : handle_(other.handle_) {
    other.handle_ = nullptr;
  }
  SharedLibrary& operator=(SharedLibrary&& other) noexcept;

  // The address of an exported symbol, or nullptr.
  [[nodiscard]] void* symbol(const char* name) const noexcept;
  // dlclose; idempotent. Nothing from the library may be used afterwards.
  void close() noexcept;
  [[nodiscard]] bool isOpen() const noexcept { return handle_ != nullptr; }

 private:
  explicit SharedLibrary(void* handle) noexcept : handle_(handle) {}
  void* handle_ = nullptr;
};

}  // namespace skr
