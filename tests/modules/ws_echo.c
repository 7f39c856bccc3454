/* SPDX-License-Identifier: Apache-2.0 */
/* A plain C module that uses every WebSocket call of ABI 1.8 (tests/web/module_ws.test.mjs):
 * it serves /echo with the subprotocol echo.v1 on the hub's web port (messages of at most 4096
 * bytes, config "queue" bytes waiting per client) and
 *   on open      sends the text "hello <peer>";
 *   "burst N S"  sends N droppable binary messages of S bytes (the first four bytes: the index,
 *                little-endian), then the text "end" (not droppable);
 *   "close C"    closes the connection with code C and the reason "asked";
 *   "unserve"    stops serving /echo (every connection closes with 1001, no event follows);
 *   anything else comes back as it came, text or binary.
 * The answer to a refused call is the text "refused <status>". Closes are logged
 * (WSECHO-CLOSED). */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct echo {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  skr_sub_handle endpoint;
} echo;

static void say(echo* e, skr_ws_conn conn, const char* text) {
  e->host->ws_send(e->ctx, conn, 1, text, strlen(text), 0);
}

static void on_opened(void* user, skr_ws_conn conn, const char* peer) {
  char line[128];
  snprintf(line, sizeof line, "hello %s", peer);
  say((echo*)user, conn, line);
}

static void burst(echo* e, skr_ws_conn conn, unsigned long n, unsigned long size) {
  unsigned char* m = (unsigned char*)calloc(1, size < 4 ? 4 : size);
  unsigned long i;
  if (m == NULL) return;
  for (i = 0; i < n; ++i) {
    m[0] = (unsigned char)(i & 0xFF);
    m[1] = (unsigned char)((i >> 8) & 0xFF);
    m[2] = (unsigned char)((i >> 16) & 0xFF);
    m[3] = (unsigned char)((i >> 24) & 0xFF);
    e->host->ws_send(e->ctx, conn, 0, m, size < 4 ? 4 : size, 1);
  }
  free(m);
  say(e, conn, "end");
}

static void on_message(void* user, skr_ws_conn conn, int text, const void* data, size_t size) {
  echo* e = (echo*)user;
  char command[64];
  unsigned long a = 0, b = 0;
  skr_status st = SKR_OK;
  if (text && size < sizeof command) {
    memcpy(command, data, size);
    command[size] = '\0';
    if (sscanf(command, "burst %lu %lu", &a, &b) == 2) {
      burst(e, conn, a, b);
      return;
    }
    if (sscanf(command, "close %lu", &a) == 1) {
      st = e->host->ws_close(e->ctx, conn, (uint16_t)a, "asked");
    } else if (strcmp(command, "unserve") == 0) {
      st = e->host->ws_unserve(e->ctx, e->endpoint);
      if (st == SKR_OK) e->endpoint = 0;
    } else {
      st = e->host->ws_send(e->ctx, conn, text, data, size, 0);
    }
  } else {
    st = e->host->ws_send(e->ctx, conn, text, data, size, 0);
  }
  if (st != SKR_OK) {
    snprintf(command, sizeof command, "refused %d", (int)st);
    say(e, conn, command);
  }
}

static void on_closed(void* user, skr_ws_conn conn, const char* why) {
  echo* e = (echo*)user;
  char line[256];
  snprintf(line, sizeof line, "%llu %s", (unsigned long long)conn, why);
  e->host->log(e->ctx, SKR_LOG_INFO, "WSECHO-CLOSED", line);
}

static skr_status echo_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  echo* e;
  if (host->abi_minor < 8) {
    host->set_error(ctx, "needs a hub with plugin ABI 1.8");
    return SKR_ERR_UNSUPPORTED;
  }
  e = (echo*)calloc(1, sizeof(echo));
  if (e == NULL) return SKR_ERR_NO_MEMORY;
  e->host = host;
  e->ctx = ctx;
  *out = e;
  return SKR_OK;
}

static skr_status echo_start(void* instance) {
  echo* e = (echo*)instance;
  skr_ws_events events;
  skr_status st;
  memset(&events, 0, sizeof events);
  events.struct_size = sizeof events;
  events.opened = on_opened;
  events.message = on_message;
  events.closed = on_closed;
  st = e->host->ws_serve(e->ctx, "/echo", "echo.v1", 4096,
                         (size_t)e->host->config_int(e->ctx, "queue", 65536), &events, e,
                         &e->endpoint);
  if (st != SKR_OK) e->host->set_error(e->ctx, "ws_serve /echo failed");
  return st;
}

static skr_status echo_stop(void* instance) {
  echo* e = (echo*)instance;
  if (e->endpoint != 0) e->host->ws_unserve(e->ctx, e->endpoint);
  e->endpoint = 0;
  return SKR_OK;
}

static void echo_fini(void* instance) {
  free(instance);
}

static const skr_module_descriptor k_descriptor = {
    sizeof(skr_module_descriptor),
    SKR_PLUGIN_ABI_MAJOR,
    SKR_PLUGIN_ABI_MINOR,
    "test_ws_echo",
    "1.0.0",
    "test: a WebSocket endpoint on the web port (ABI 1.8)",
    0,
    echo_init,
    echo_start,
    echo_stop,
    echo_fini,
    NULL,
    0,
    NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
