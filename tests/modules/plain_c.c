/* SPDX-License-Identifier: Apache-2.0 */
/* A working module written in plain C against plugin.h only. Counts fast ticks (read by the
 * test through test_plain_c_ticks) and logs PLAIN-C-INIT/START/STOP/FINI. */
#include <skrobot/plugin.h>

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>

typedef struct plain {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  skr_tick_handle tick;
} plain;

static atomic_int g_ticks; /* read by the test from another thread */

SKR_EXPORT int test_plain_c_ticks(void) {
  return g_ticks;
}

static void on_fast(void* user) {
  (void)user;
  atomic_fetch_add(&g_ticks, 1);
}

static skr_status plain_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  char line[160];
  plain* p = (plain*)calloc(1, sizeof *p);
  if (p == NULL) return SKR_ERR_NO_MEMORY;
  p->host = host;
  p->ctx = ctx;
  atomic_store(&g_ticks, 0);
  snprintf(line, sizeof line, "label=%s factor=%lld ratio=%.2f verbose=%d json=%s",
           host->config_string(ctx, "label", "none"), (long long)host->config_int(ctx, "factor", 1),
           host->config_double(ctx, "ratio", 0.5), host->config_bool(ctx, "verbose", 0),
           host->config_json(ctx));
  host->log(ctx, SKR_LOG_INFO, "PLAIN-C-INIT", line);
  *out = p;
  return SKR_OK;
}

static skr_status plain_start(void* instance) {
  plain* p = (plain*)instance;
  skr_status st = p->host->tick_add(p->ctx, SKR_TICK_FAST, on_fast, p, &p->tick);
  if (st != SKR_OK) {
    p->host->set_error(p->ctx, p->host->strerror(st));
    return st;
  }
  p->host->log(p->ctx, SKR_LOG_INFO, "PLAIN-C-START", p->host->module_name(p->ctx));
  return SKR_OK;
}

static skr_status plain_stop(void* instance) {
  plain* p = (plain*)instance;
  if (p->tick != 0) p->host->tick_remove(p->ctx, p->tick);
  p->tick = 0;
  p->host->log(p->ctx, SKR_LOG_INFO, "PLAIN-C-STOP", "stopped");
  return SKR_OK;
}

static void plain_fini(void* instance) {
  plain* p = (plain*)instance;
  p->host->log(p->ctx, SKR_LOG_INFO, "PLAIN-C-FINI", "freed");
  free(p);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "plain_c",
                                                   "0.1.0",
                                                   "a module in plain C",
                                                   0,
                                                   plain_init,
                                                   plain_start,
                                                   plain_stop,
                                                   plain_fini,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
