/* SPDX-License-Identifier: Apache-2.0 */
/* init fails: CASE_INIT_MESSAGE explains itself with set_error; CASE_INIT_STATUS only returns a
 * status, as a careless C module would. Both register a tick first: the host must remove it. */
#include <skrobot/plugin.h>

static void on_tick(void* user) {
  (void)user;
}

static skr_status failing_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  skr_tick_handle h = 0;
  (void)out;
  host->tick_add(ctx, SKR_TICK_FAST, on_tick, 0, &h);
#ifdef CASE_INIT_MESSAGE
  host->set_error(ctx, "cannot open /dev/robot-arm: no such device");
  return SKR_ERR_FAILED;
#else
  return SKR_ERR_NOT_FOUND;
#endif
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "failing",
                                                   "0.1.0",
                                                   "init fails",
                                                   0,
                                                   failing_init,
                                                   0,
                                                   0,
                                                   0,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
