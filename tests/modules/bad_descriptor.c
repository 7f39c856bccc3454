/* SPDX-License-Identifier: Apache-2.0 */
/* One descriptor defect per build (CASE_*): the host must refuse each at load. */
#include <skrobot/plugin.h>

static skr_status bad_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  (void)host;
  (void)ctx;
  (void)out;
  return SKR_OK;
}

#if defined(CASE_ABI_MAJOR)
#define MAJOR (SKR_PLUGIN_ABI_MAJOR + 1)
#define MINOR 0
#define SIZE sizeof(skr_module_descriptor)
#elif defined(CASE_ABI_MINOR)
#define MAJOR SKR_PLUGIN_ABI_MAJOR
#define MINOR (SKR_PLUGIN_ABI_MINOR + 1)
#define SIZE sizeof(skr_module_descriptor)
#else
#define MAJOR SKR_PLUGIN_ABI_MAJOR
#define MINOR SKR_PLUGIN_ABI_MINOR
#define SIZE 16
#endif

static const skr_module_descriptor k_descriptor = {
    SIZE, MAJOR, MINOR, "bad", "0.1.0", "a defective descriptor", 0, bad_init, 0, 0, 0, 0, 0, 0};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
#ifdef CASE_NULL_DESCRIPTOR
  return k_descriptor.name != 0 ? 0 : &k_descriptor; /* always NULL */
#else
  return &k_descriptor;
#endif
}
