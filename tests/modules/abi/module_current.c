/* SPDX-License-Identifier: Apache-2.0 */
/* A module of the ABI of the header it is compiled against, by abi_compat_test.sh at test time:
 * the current plugin.h, or a copy with the minor (or the major) raised by one, which the hub must
 * refuse. It declares its config keys (ABI 1.2): "count" (integer 1..100, default 5) and "label"
 * (a non-empty string, required), and logs ABI<major><minor>-INIT with what it read.
 *
 * With ABI_TEST_HEADER_ONLY the entry returns a descriptor whose 8-byte header (struct_size,
 * abi_major, abi_minor) is the last readable bytes before a page without access: a host that reads
 * any other field of it (before refusing it) crashes. */
#define _DEFAULT_SOURCE /* mmap, MAP_ANONYMOUS */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <string.h>
#ifdef ABI_TEST_HEADER_ONLY
#include <sys/mman.h>
#include <unistd.h>
#endif

#define ABI_TEXT(x) #x
#define ABI_STR(x) ABI_TEXT(x)
#define ABI_VERSION ABI_STR(SKR_PLUGIN_ABI_MAJOR) "." ABI_STR(SKR_PLUGIN_ABI_MINOR)
#define ABI_TAG "ABI" ABI_STR(SKR_PLUGIN_ABI_MAJOR) ABI_STR(SKR_PLUGIN_ABI_MINOR) "-INIT"

static const skr_config_key k_keys[] = {
    {"count", SKR_CONFIG_INT, SKR_CONFIG_MIN | SKR_CONFIG_MAX, "5", 1, 100, NULL, "how many"},
    {"label", SKR_CONFIG_STRING, SKR_CONFIG_REQUIRED | SKR_CONFIG_NON_EMPTY, NULL, 0, 0, NULL,
     "a name to log"},
};

static skr_status current_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  char line[256];
  snprintf(line, sizeof line, "count=%lld label=%s has_count=%d",
           (long long)host->config_int(ctx, "count", -1), host->config_string(ctx, "label", "none"),
           host->config_has(ctx, "count"));
  host->log(ctx, SKR_LOG_INFO, ABI_TAG, line);
  *out = NULL;
  return SKR_OK;
}

static const skr_module_descriptor k_descriptor = {
    sizeof(skr_module_descriptor),
    SKR_PLUGIN_ABI_MAJOR,
    SKR_PLUGIN_ABI_MINOR,
    "abi_module",
    ABI_VERSION ".0",
    "test: built against plugin.h " ABI_VERSION,
    0,
    current_init,
    NULL,
    NULL,
    NULL,
    k_keys,
    sizeof k_keys / sizeof k_keys[0],
#if SKR_PLUGIN_ABI_MAJOR > 1 || SKR_PLUGIN_ABI_MINOR >= 11
    NULL /* reconfigure */
#endif
};

#ifdef ABI_TEST_HEADER_ONLY
enum { kHeaderBytes = 8 };

static const skr_module_descriptor* header_only(void) {
  static unsigned char* header = NULL;
  if (header == NULL) {
    const size_t page = (size_t)sysconf(_SC_PAGESIZE);
    unsigned char* p = (unsigned char*)mmap(NULL, 2 * page, PROT_READ | PROT_WRITE,
                                            MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) return NULL;
    memcpy(p + page - kHeaderBytes, &k_descriptor, kHeaderBytes);
    if (mprotect(p + page, page, PROT_NONE) != 0 || mprotect(p, page, PROT_READ) != 0) {
      return NULL;
    }
    header = p + page - kHeaderBytes;  // the mapping outlives dlclose: two pages, per process
  }
  return (const skr_module_descriptor*)(const void*)header;
}
#endif

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
#ifdef ABI_TEST_HEADER_ONLY
  return header_only();
#else
  return &k_descriptor;
#endif
}
