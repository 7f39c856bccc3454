/* SPDX-License-Identifier: Apache-2.0 */
/* A module of ABI 1.1, compiled at test time against the frozen 1.1 header (abi/1.1) by
 * abi_compat_test.sh: the 1.0 config calls, then the channel and database calls of 1.1. At start
 * it creates the streaming channel "<name>.numbers", subscribes to it, publishes "count=<count>"
 * and logs ABI11-DATA with what came back; it writes that text to its own database and logs
 * ABI11-DB with what db_get reads back. */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if SKR_PLUGIN_ABI_MAJOR != 1 || SKR_PLUGIN_ABI_MINOR != 1
#error "module_1_1.c is built against the frozen 1.1 header"
#endif

typedef struct mid_module {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  long long count;
} mid_module;

static void on_data(void* user, uint16_t chan_id, const void* data, size_t size) {
  mid_module* m = (mid_module*)user;
  char line[128];
  (void)chan_id;
  snprintf(line, sizeof line, "%.*s", (int)size, (const char*)data);
  m->host->log(m->ctx, SKR_LOG_INFO, "ABI11-DATA", line);
}

static skr_status mid_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  char line[256];
  mid_module* m;
  if (host->abi_minor < 1) {
    host->set_error(ctx, "needs a hub with plugin ABI 1.1");
    return SKR_ERR_UNSUPPORTED;
  }
  m = (mid_module*)calloc(1, sizeof(mid_module));
  if (m == NULL) return SKR_ERR_NO_MEMORY;
  m->host = host;
  m->ctx = ctx;
  m->count = (long long)host->config_int(ctx, "count", 7);
  snprintf(line, sizeof line, "count=%lld label=%s", m->count,
           host->config_string(ctx, "label", "none"));
  host->log(ctx, SKR_LOG_INFO, "ABI11-INIT", line);
  *out = m;
  return SKR_OK;
}

static skr_status mid_start(void* instance) {
  mid_module* m = (mid_module*)instance;
  const char* name = m->host->module_name(m->ctx);
  char full[128];
  char text[64];
  char json[80];
  char back[80];
  size_t len = 0;
  uint16_t chan = 0;
  skr_sub_handle sub = 0;
  skr_status s = m->host->channel_create(m->ctx, "numbers", SKR_CHANNEL_STREAMING, "text/plain",
                                         NULL, NULL, NULL, m, &chan);
  if (s != SKR_OK) return s;
  snprintf(full, sizeof full, "%s.numbers", name);
  s = m->host->subscribe(m->ctx, full, on_data, m, &sub);
  if (s != SKR_OK) return s;
  snprintf(text, sizeof text, "count=%lld", m->count);
  s = m->host->publish(m->ctx, chan, text, strlen(text));
  if (s != SKR_OK) return s;
  snprintf(json, sizeof json, "\"%s\"", text);
  s = m->host->db_set(m->ctx, name, "published", json);
  if (s != SKR_OK) return s;
  s = m->host->db_get(m->ctx, name, "published", back, sizeof back, &len);
  if (s != SKR_OK) return s;
  m->host->log(m->ctx, SKR_LOG_INFO, "ABI11-DB", back);
  return SKR_OK;
}

static void mid_fini(void* instance) {
  free(instance);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "abi_1_1",
                                                   "1.1.0",
                                                   "test: built against the frozen ABI 1.1 header",
                                                   0,
                                                   mid_init,
                                                   mid_start,
                                                   NULL,
                                                   mid_fini};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
