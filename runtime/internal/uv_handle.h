// SPDX-License-Identifier: Apache-2.0
// Heap-allocated libuv handles whose memory goes with their close callback. Internal.
#pragma once

#include <uv.h>

namespace skr {

// A new handle of type H with `data` set to `owner`; initialise it with uv_*_init.
template <typename H, typename Owner>
H* newUvHandle(Owner* owner) {
  auto* h = new H{};
  h->data = owner;
  return h;
}

// Closes the handle (if any); libuv frees it in the close callback. Sets `h` to null.
template <typename H>
void closeUvHandle(H*& h) {
  if (h == nullptr) return;
  uv_close(reinterpret_cast<uv_handle_t*>(h),
           [](uv_handle_t* handle) { delete reinterpret_cast<H*>(handle); });
  h = nullptr;
}

}  // namespace skr
