// SPDX-License-Identifier: Apache-2.0
// Keeps an already loaded shared library mapped until the process exits (header-only).
//
// The hub unloads a module with dlclose (at --list-modules, after a failed start, on reload). Some
// libraries cannot be unmapped cleanly: JACK (under PortAudio) keeps static C++ allocations and
// threads, espeak-ng stays initialised for the process's life, Fast DDS keeps its factory and log
// singletons. A module that links one pins it when the module is loaded, at namespace scope:
//
//   [[maybe_unused]] const bool kPinned = skr::support::pinLoadedLibrary("libportaudio.so.2");
//
// so that its dlclose leaves that library (and what it links) in place.
#pragma once

#include <dlfcn.h>

namespace skr::support {

// dlopen(soname, RTLD_NOLOAD | RTLD_NODELETE): true when the library was loaded and is now pinned.
// RTLD_NOLOAD: only a library the module already brought in; the reference it adds is never
// dropped, which is the point.
inline bool pinLoadedLibrary(const char* soname) noexcept {
  return dlopen(soname, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE) != nullptr;
}

}  // namespace skr::support
