/* SPDX-License-Identifier: Apache-2.0 */
/* A plain C module that offers physical paths (ABI 1.7), like a camera in the hub:
 *   test_paths_camera.frames  streaming, shared memory and direct paths (4 slots of 64 KB): on
 *                             each fast tick while it has subscribers, one frame
 *                             "frame <n> " followed by 2000 bytes of the letter 'a' + n % 26.
 * Even frames are filled in place (publish_begin / publish_commit), odd ones published as a copy
 * (publish); when no slot is free, the even ones are published as a copy too. At start it
 * checks the refusals of the calls (PATHS-CHECKS in the log). */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FILL_BYTES 2000

typedef struct camera {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  uint16_t frames;
  int subscribed;
  uint64_t n;
  skr_tick_handle tick;
} camera;

static size_t render(uint64_t n, char* out, size_t cap) {
  int head = snprintf(out, cap, "frame %llu ", (unsigned long long)n);
  if (head < 0 || (size_t)head + FILL_BYTES > cap) return 0;
  memset(out + head, 'a' + (int)(n % 26), FILL_BYTES);
  return (size_t)head + FILL_BYTES;
}

static void on_tick(void* user) {
  camera* c = (camera*)user;
  const skr_host_api* h = c->host;
  void* slot = NULL;
  size_t cap = 0;
  char copy[64 + FILL_BYTES];
  if (!c->subscribed) return;
  ++c->n;
  if (c->n % 2 == 0 && h->publish_begin(c->ctx, c->frames, &slot, &cap) == SKR_OK) {
    const size_t size = render(c->n, (char*)slot, cap);
    h->publish_commit(c->ctx, c->frames, size, (int64_t)c->n);
    return;
  }
  h->publish(c->ctx, c->frames, copy, render(c->n, copy, sizeof copy));
}

static void on_subscribers(void* user, uint16_t chan_id, int first) {
  (void)chan_id;
  ((camera*)user)->subscribed = first;
}

static skr_status camera_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  camera* c;
  if (host->abi_minor < 7) {
    host->set_error(ctx, "needs a hub with plugin ABI 1.7");
    return SKR_ERR_UNSUPPORTED;
  }
  c = (camera*)calloc(1, sizeof(camera));
  if (c == NULL) return SKR_ERR_NO_MEMORY;
  c->host = host;
  c->ctx = ctx;
  *out = c;
  return SKR_OK;
}

/* The refusals of the ABI 1.7 calls, and a channel whose paths go with it: logs PATHS-CHECKS ok,
 * or the first one that did not hold. */
static void check_calls(camera* c, const skr_path_options* paths) {
  const skr_host_api* h = c->host;
  const char* wrong = NULL;
  skr_path_options none = *paths;
  uint16_t svc = 0, spare = 0;
  void* slot = NULL;
  size_t cap = 0;
  none.kinds = 0;
  if (h->channel_paths(c->ctx, c->frames, paths) != SKR_ERR_INVALID_ARGUMENT) {
    wrong = "paths offered twice";
  } else if (h->channel_paths(c->ctx, 0, paths) != SKR_ERR_NOT_FOUND) {
    wrong = "paths for a channel of nobody's";
  } else if (h->channel_create(c->ctx, "svc", SKR_CHANNEL_SERVICE, "", NULL, NULL, NULL, c, &svc) !=
                 SKR_OK ||
             h->channel_paths(c->ctx, svc, paths) == SKR_OK) {
    wrong = "paths for a service channel";
  } else if (h->channel_create(c->ctx, "spare", SKR_CHANNEL_STREAMING, "", NULL, NULL, NULL, c,
                               &spare) != SKR_OK ||
             h->channel_paths(c->ctx, spare, &none) != SKR_ERR_INVALID_ARGUMENT) {
    wrong = "no kinds";
  } else if (h->publish_commit(c->ctx, spare, 1, 0) != SKR_ERR_BAD_STATE) {
    wrong = "a commit without a slot";
  } else if (h->publish_begin(c->ctx, spare, &slot, &cap) != SKR_ERR_NOT_FOUND) {
    wrong = "a slot of a channel without paths";
  } else if (h->channel_paths(c->ctx, spare, paths) != SKR_OK ||
             h->publish_begin(c->ctx, spare, &slot, &cap) != SKR_OK || cap != paths->slot_bytes ||
             h->publish_commit(c->ctx, spare, cap + 1, 0) != SKR_ERR_INVALID_ARGUMENT ||
             h->publish_commit(c->ctx, spare, 3, 0) != SKR_OK) {
    wrong = "a slot filled in place";
  } else if (h->channel_remove(c->ctx, spare) != SKR_OK ||
             h->publish_begin(c->ctx, spare, &slot, &cap) != SKR_ERR_NOT_FOUND) {
    wrong = "paths after channel_remove";
  } else if (h->channel_create(c->ctx, "spare", SKR_CHANNEL_STREAMING, "", NULL, NULL, NULL, c,
                               &spare) != SKR_OK ||
             h->channel_paths(c->ctx, spare, paths) != SKR_OK ||
             h->channel_remove(c->ctx, spare) != SKR_OK) {
    wrong = "paths for a channel created again";
  }
  h->channel_remove(c->ctx, svc);
  h->log(c->ctx, wrong == NULL ? SKR_LOG_INFO : SKR_LOG_ERROR, "PATHS-CHECKS",
         wrong == NULL ? "ok" : wrong);
}

static skr_status camera_start(void* instance) {
  camera* c = (camera*)instance;
  const skr_host_api* h = c->host;
  skr_path_options paths;
  skr_status r = h->channel_create(c->ctx, "frames", SKR_CHANNEL_STREAMING, "text/plain", NULL,
                                   on_subscribers, NULL, c, &c->frames);
  memset(&paths, 0, sizeof paths);
  paths.struct_size = sizeof paths;
  paths.kinds = SKR_PATH_SHM | SKR_PATH_DIRECT;
  paths.ring_slots = 4;
  paths.slot_bytes = 1 << 16;
  if (r == SKR_OK) r = h->channel_paths(c->ctx, c->frames, &paths);
  if (r == SKR_OK) check_calls(c, &paths);
  if (r == SKR_OK) r = h->tick_add(c->ctx, SKR_TICK_FAST, on_tick, c, &c->tick);
  return r;
}

static void camera_fini(void* instance) {
  free(instance);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "paths_camera",
                                                   "1.0.0",
                                                   "test: physical paths from a C module",
                                                   0,
                                                   camera_init,
                                                   camera_start,
                                                   NULL,
                                                   camera_fini,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
