// SPDX-License-Identifier: Apache-2.0
// Keeps an already loaded shared library mapped until the process exits.
//
// The hub unloads a module with dlclose (at --list-modules, after a failed start, on reload). Sound
// libraries cannot be unmapped cleanly: JACK (under PortAudio) keeps static C++ allocations and
// threads, and espeak-ng stays initialised for the process's life (synthesizer.cpp). A module that
// links one pins it when it is loaded, so that its dlclose leaves that library (and what it links)
// in place.
#pragma once

namespace skr::audio {

// dlopen(soname, RTLD_NOLOAD | RTLD_NODELETE): true when the library was loaded and is now pinned.
bool pinLoadedLibrary(const char* soname) noexcept;

}  // namespace skr::audio
