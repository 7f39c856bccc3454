/* SPDX-License-Identifier: Apache-2.0 */
/* A plain C module that uses the FlowNetwork calls of ABI 1.1:
 *   test_channel_echo.out  streaming: republishes what arrives on guest.in (a subscription made
 *                          before guest.in exists), produced only while someone listens
 *   test_channel_echo.svc  service: answers every request with {"echo": <value>, "cmd": <cmd>}
 *                          ("sleep" <ms> first holds its thread that long)
 * and writes the number of echoed messages to its own database, key "echoed". It watches
 * channels and logs ECHO-SEEN <name> when guest.late is added. Run on its own thread (ABI 1.10),
 * every call comes from that thread; a callback on any other thread than init's logs
 * ECHO-WRONG-THREAD. ECHO-THREAD says which loop it runs on ("own" or "main"). */
#include <skrobot/plugin.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct echo {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  uint16_t out;
  uint16_t svc;
  int listeners;
  long echoed;
  pthread_t thread; /* init's: the module's loop thread */
} echo;

static void check_thread(echo* e, const char* what) {
  if (!pthread_equal(pthread_self(), e->thread))
    e->host->log(e->ctx, SKR_LOG_ERROR, "ECHO-WRONG-THREAD", what);
}

static void on_subscribers(void* user, uint16_t chan_id, int first) {
  echo* e = (echo*)user;
  (void)chan_id;
  check_thread(e, "on_subscribers");
  e->listeners = first;
  e->host->log(e->ctx, SKR_LOG_INFO, "ECHO-LISTENERS", first ? "first" : "none");
}

static void on_data(void* user, uint16_t chan_id, const void* data, size_t size) {
  echo* e = (echo*)user;
  char count[32];
  (void)chan_id;
  check_thread(e, "on_data");
  if (!e->listeners) return;
  if (e->host->publish(e->ctx, e->out, data, size) != SKR_OK) return;
  snprintf(count, sizeof count, "%ld", ++e->echoed);
  e->host->db_set(e->ctx, "test_channel_echo", "echoed", count);
}

static void on_request(void* user, uint16_t chan_id, uint64_t request, const char* command,
                       const char* requester, const char* value_json) {
  echo* e = (echo*)user;
  size_t n = strlen(value_json) + strlen(command) + 32;
  char* answer = (char*)malloc(n);
  (void)requester;
  check_thread(e, "on_request");
  if (strcmp(command, "sleep") == 0) usleep((useconds_t)atoi(value_json) * 1000u);
  snprintf(answer, n, "{\"cmd\":\"%s\",\"echo\":%s}", command, value_json);
  e->host->service_respond(e->ctx, chan_id, request, answer);
  free(answer);
}

static void on_channel(void* user, uint16_t chan_id, const char* name, skr_channel_kind kind,
                       const char* mime, int added) {
  echo* e = (echo*)user;
  (void)chan_id;
  (void)kind;
  (void)mime;
  check_thread(e, "on_channel");
  if (added && strcmp(name, "guest.late") == 0)
    e->host->log(e->ctx, SKR_LOG_INFO, "ECHO-SEEN", name);
}

static skr_status echo_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  echo* e = (echo*)calloc(1, sizeof(echo));
  if (e == NULL) return SKR_ERR_NO_MEMORY;
  if (host->abi_minor < 6) {
    host->set_error(ctx, "needs a hub with plugin ABI 1.6");
    free(e);
    return SKR_ERR_UNSUPPORTED;
  }
  if (host->loop_info(ctx)->own_thread && host->abi_minor < 10) {
    host->set_error(ctx, "on its own thread, needs a hub with plugin ABI 1.10");
    free(e);
    return SKR_ERR_UNSUPPORTED;
  }
  e->host = host;
  e->ctx = ctx;
  e->thread = pthread_self();
  host->log(ctx, SKR_LOG_INFO, "ECHO-THREAD", host->loop_info(ctx)->own_thread ? "own" : "main");
  *out = e;
  return SKR_OK;
}

static skr_status echo_start(void* instance) {
  echo* e = (echo*)instance;
  skr_sub_handle sub = 0, watch = 0;
  skr_status s = e->host->channel_create(e->ctx, "out", SKR_CHANNEL_STREAMING, "text/plain",
                                         "{\"rate_hz\": 0, \"note\": \"echo of guest.in\"}",
                                         on_subscribers, NULL, e, &e->out);
  if (s != SKR_OK) return s;
  s = e->host->channel_create(e->ctx, "svc", SKR_CHANNEL_SERVICE, "application/json", NULL, NULL,
                              on_request, e, &e->svc);
  if (s != SKR_OK) return s;
  s = e->host->channel_watch(e->ctx, on_channel, e, &watch);
  if (s != SKR_OK) return s;
  return e->host->subscribe(e->ctx, "guest.in", on_data, e, &sub);
}

static void echo_fini(void* instance) {
  free(instance);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "channel_echo",
                                                   "1.0.0",
                                                   "test: FlowNetwork calls from C",
                                                   0,
                                                   echo_init,
                                                   echo_start,
                                                   NULL,
                                                   echo_fini,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
