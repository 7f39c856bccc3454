/* SPDX-License-Identifier: Apache-2.0 */
/* A module of ABI 1.0, compiled at test time against the frozen 1.0 header (abi/1.0) by
 * abi_compat_test.sh: the lifecycle and the config calls of 1.0. Logs ABI10-INIT with what it
 * read from its config, then ABI10-START, ABI10-STOP and ABI10-FINI. */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <stdlib.h>

#if SKR_PLUGIN_ABI_MAJOR != 1 || SKR_PLUGIN_ABI_MINOR != 0
#error "module_1_0.c is built against the frozen 1.0 header"
#endif

typedef struct old_module {
  const skr_host_api* host;
  skr_module_ctx* ctx;
} old_module;

static void say(old_module* m, const char* tag) {
  m->host->log(m->ctx, SKR_LOG_INFO, tag, m->host->module_name(m->ctx));
}

static skr_status old_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  char line[256];
  old_module* m = (old_module*)calloc(1, sizeof(old_module));
  if (m == NULL) return SKR_ERR_NO_MEMORY;
  m->host = host;
  m->ctx = ctx;
  snprintf(line, sizeof line, "count=%lld label=%s host=%u.%u",
           (long long)host->config_int(ctx, "count", 7), host->config_string(ctx, "label", "none"),
           (unsigned)host->abi_major, (unsigned)host->abi_minor);
  host->log(ctx, SKR_LOG_INFO, "ABI10-INIT", line);
  *out = m;
  return SKR_OK;
}

static skr_status old_start(void* instance) {
  say((old_module*)instance, "ABI10-START");
  return SKR_OK;
}

static skr_status old_stop(void* instance) {
  say((old_module*)instance, "ABI10-STOP");
  return SKR_OK;
}

static void old_fini(void* instance) {
  say((old_module*)instance, "ABI10-FINI");
  free(instance);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "abi_1_0",
                                                   "1.0.0",
                                                   "test: built against the frozen ABI 1.0 header",
                                                   0,
                                                   old_init,
                                                   old_start,
                                                   old_stop,
                                                   old_fini};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
