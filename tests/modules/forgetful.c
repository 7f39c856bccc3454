/* SPDX-License-Identifier: Apache-2.0 */
/* Registers ticks and never removes them; posts work during stop that can never run. The host
 * must remove the ticks and cancel the work (FORGET-CANCEL), never run it (FORGET-RAN). */
#include <skrobot/plugin.h>

#include <stdatomic.h>

static const skr_host_api* g_host;
static skr_module_ctx* g_ctx;
static atomic_int g_ticks; /* read by the test from another thread */

SKR_EXPORT int test_forgetful_ticks(void) {
  return g_ticks;
}

static void on_tick(void* user) {
  (void)user;
  atomic_fetch_add(&g_ticks, 1);
}
static void on_posted(void* user) {
  (void)user;
  g_host->log(g_ctx, SKR_LOG_INFO, "FORGET-RAN", "posted work ran after stop");
}
static void on_cancel(void* user) {
  (void)user;
  g_host->log(g_ctx, SKR_LOG_INFO, "FORGET-CANCEL", "posted work cancelled");
}

static skr_status forget_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  skr_tick_handle h = 0;
  g_host = host;
  g_ctx = ctx;
  atomic_store(&g_ticks, 0);
  *out = 0;
  /* Registered during init: must stay silent until start. */
  return host->tick_add(ctx, SKR_TICK_FAST, on_tick, 0, &h);
}

static skr_status forget_start(void* instance) {
  skr_tick_handle h = 0;
  (void)instance;
  return g_host->tick_add(g_ctx, SKR_TICK_SLOW, on_tick, 0, &h);
}

static skr_status forget_stop(void* instance) {
  (void)instance;
  return g_host->post(g_ctx, on_posted, on_cancel, 0);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "forgetful",
                                                   "0.1.0",
                                                   "leaves its registrations to the host",
                                                   0,
                                                   forget_init,
                                                   forget_start,
                                                   forget_stop,
                                                   0,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
