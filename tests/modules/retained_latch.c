/* SPDX-License-Identifier: Apache-2.0 */
/* A plain C module that uses the retained messages of ABI 1.9:
 *   test_retained_latch.latched  streaming, property retained: true
 * driven by what arrives on guest.set:
 *   "key=value"  publish_retained("value") under "key"
 *   "!value"     publish("value"), not retained
 *   "-key"       retain_clear("key");  "-" alone: retain_clear(NULL), every key
 *   "?"          one more subscription of its own to test_retained_latch.latched (at most 8):
 *                subscription n logs LATCH-HEARD "<n>:<payload>" for each message it gets
 * A refused call is logged as LATCH-REFUSED with the call and its status. */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct latch latch;
typedef struct listener {
  latch* owner;
  int n;
} listener;

struct latch {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  uint16_t out;
  listener listeners[8];
  int listening;
};

static void on_own(void* user, uint16_t chan_id, const void* data, size_t size) {
  listener* who = (listener*)user;
  char line[600];
  (void)chan_id;
  snprintf(line, sizeof line, "%d:%.*s", who->n, (int)(size < 512 ? size : 512), (const char*)data);
  who->owner->host->log(who->owner->ctx, SKR_LOG_INFO, "LATCH-HEARD", line);
}

static void refused(latch* l, const char* call, skr_status s) {
  char line[128];
  snprintf(line, sizeof line, "%s: %s", call, l->host->strerror(s));
  l->host->log(l->ctx, SKR_LOG_WARN, "LATCH-REFUSED", line);
}

static void on_data(void* user, uint16_t chan_id, const void* data, size_t size) {
  latch* l = (latch*)user;
  char text[512];
  skr_status s;
  char* eq;
  (void)chan_id;
  if (size == 0 || size >= sizeof text) return;
  memcpy(text, data, size);
  text[size] = '\0';
  if (text[0] == '?' && l->listening < 8) {
    skr_sub_handle h = 0;
    listener* who = &l->listeners[l->listening++];
    who->owner = l;
    who->n = l->listening;
    s = l->host->subscribe(l->ctx, "test_retained_latch.latched", on_own, who, &h);
    if (s != SKR_OK) refused(l, "subscribe", s);
  } else if (text[0] == '!') {
    s = l->host->publish(l->ctx, l->out, text + 1, size - 1);
    if (s != SKR_OK) refused(l, "publish", s);
  } else if (text[0] == '-') {
    s = l->host->retain_clear(l->ctx, l->out, size > 1 ? text + 1 : NULL);
    if (s != SKR_OK) refused(l, "retain_clear", s);
  } else if ((eq = strchr(text, '=')) != NULL) {
    *eq = '\0';
    s = l->host->publish_retained(l->ctx, l->out, text, eq + 1, strlen(eq + 1));
    if (s != SKR_OK) refused(l, "publish_retained", s);
  }
}

static skr_status latch_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  latch* l = (latch*)calloc(1, sizeof(latch));
  if (l == NULL) return SKR_ERR_NO_MEMORY;
  if (host->abi_minor < 9) {
    host->set_error(ctx, "needs a hub with plugin ABI 1.9");
    free(l);
    return SKR_ERR_UNSUPPORTED;
  }
  l->host = host;
  l->ctx = ctx;
  *out = l;
  return SKR_OK;
}

static skr_status latch_start(void* instance) {
  latch* l = (latch*)instance;
  skr_sub_handle sub = 0;
  skr_status s = l->host->channel_create(l->ctx, "latched", SKR_CHANNEL_STREAMING, "text/plain",
                                         "{\"retained\": true}", NULL, NULL, l, &l->out);
  if (s != SKR_OK) return s;
  return l->host->subscribe(l->ctx, "guest.set", on_data, l, &sub);
}

static void latch_fini(void* instance) {
  free(instance);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "retained_latch",
                                                   "1.0.0",
                                                   "test: retained messages from C",
                                                   0,
                                                   latch_init,
                                                   latch_start,
                                                   NULL,
                                                   latch_fini,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
