/* SPDX-License-Identifier: Apache-2.0 */
/* A plain C module on the sync pulse (ABI 1.5):
 *   test_sync_step.beat   a sync source: one pulse for each message on guest.trigger
 *   test_sync_step.ticks  streaming: "<seq>:<dropped>" for each pulse of guest.clock, which it
 *                         follows (every config "every") from before guest.clock exists
 * With config "later": true it finishes a pulse only when a message arrives on guest.finish
 * (SKR_SYNC_DONE_LATER), so that a test can make it lag. The message "unfollow" on
 * guest.trigger makes it stop following instead of pulsing. */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct step {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  uint16_t beat;
  uint16_t ticks;
  skr_sub_handle follow;
  uint64_t busy_with; /* the pulse not finished yet (later mode) */
} step;

static void on_pulse(void* user, uint16_t chan_id, uint64_t seq, uint64_t source_time_ns,
                     uint32_t dropped) {
  step* s = (step*)user;
  char line[64];
  (void)chan_id;
  (void)source_time_ns;
  s->busy_with = seq;
  snprintf(line, sizeof line, "%llu:%u", (unsigned long long)seq, dropped);
  s->host->publish(s->ctx, s->ticks, line, strlen(line));
}

static void on_trigger(void* user, uint16_t chan_id, const void* data, size_t size) {
  step* s = (step*)user;
  (void)chan_id;
  if (size == 8 && memcmp(data, "unfollow", 8) == 0) {
    s->host->sync_unfollow(s->ctx, s->follow);
    s->follow = 0;
    return;
  }
  s->host->sync_pulse(s->ctx, s->beat);
}

static void on_finish(void* user, uint16_t chan_id, const void* data, size_t size) {
  step* s = (step*)user;
  (void)chan_id;
  (void)data;
  (void)size;
  s->host->sync_done(s->ctx, s->follow, s->busy_with);
}

static skr_status step_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  step* s;
  if (host->abi_minor < 5) {
    host->set_error(ctx, "needs a hub with plugin ABI 1.5");
    return SKR_ERR_UNSUPPORTED;
  }
  s = (step*)calloc(1, sizeof(step));
  if (s == NULL) return SKR_ERR_NO_MEMORY;
  s->host = host;
  s->ctx = ctx;
  *out = s;
  return SKR_OK;
}

static skr_status step_start(void* instance) {
  step* s = (step*)instance;
  const skr_host_api* h = s->host;
  const uint32_t every = (uint32_t)h->config_int(s->ctx, "every", 1);
  const uint32_t flags = h->config_bool(s->ctx, "later", 0) ? SKR_SYNC_DONE_LATER : 0;
  skr_sub_handle sub = 0;
  skr_status r =
      h->channel_create(s->ctx, "beat", SKR_CHANNEL_SYNC, "", NULL, NULL, NULL, s, &s->beat);
  if (r == SKR_OK) {
    r = h->channel_create(s->ctx, "ticks", SKR_CHANNEL_STREAMING, "text/plain", NULL, NULL, NULL, s,
                          &s->ticks);
  }
  if (r == SKR_OK) r = h->sync_follow(s->ctx, "guest.clock", every, flags, on_pulse, s, &s->follow);
  if (r == SKR_OK) r = h->subscribe(s->ctx, "guest.trigger", on_trigger, s, &sub);
  if (r == SKR_OK) r = h->subscribe(s->ctx, "guest.finish", on_finish, s, &sub);
  return r;
}

static void step_fini(void* instance) {
  free(instance);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "sync_step",
                                                   "1.0.0",
                                                   "test: the sync pulse from C",
                                                   0,
                                                   step_init,
                                                   step_start,
                                                   NULL,
                                                   step_fini,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
