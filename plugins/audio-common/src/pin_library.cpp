// SPDX-License-Identifier: Apache-2.0
#include <skrobot/audio/pin_library.h>

#include <dlfcn.h>

namespace skr::audio {

bool pinLoadedLibrary(const char* soname) noexcept {
  // RTLD_NOLOAD: only a library this module already brought in; the reference it adds is never
  // dropped, which is the point.
  return dlopen(soname, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE) != nullptr;
}

}  // namespace skr::audio
