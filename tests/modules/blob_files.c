/* SPDX-License-Identifier: Apache-2.0 */
/* A plain C module that uses the blob channel calls of ABI 1.4:
 *   <module>.files   its blob channel, which it subscribes to (change events arrive as data)
 *   <module>.report  streaming: what happened, one line each, once someone listens:
 *     "bad:<status>"               blob_get of "../x": refused at once
 *     "event:<json>"               a change of <module>.files
 *     "put:<status>"               blob_put of "a/hello.txt"
 *     "get:<status>:<data>"        blob_get of it
 *     "list:<status>:<json>"       blob_list of "a"
 *     "removed:<status>"           blob_do REMOVE of it
 *     "missing:<status>:<message>" blob_get of it again */
#include <skrobot/plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct files {
  const skr_host_api* host;
  skr_module_ctx* ctx;
  uint16_t files;
  uint16_t report;
} files;

static void report(files* f, const char* line) {
  f->host->publish(f->ctx, f->report, line, strlen(line));
}

static void report_data(files* f, const char* what, skr_status status, const void* data,
                        size_t size) {
  char line[512];
  int n = snprintf(line, sizeof line, "%s:%d:", what, (int)status);
  if (size > 0 && ((const char*)data)[size - 1] == '\0') --size; /* a C string */
  if (n > 0 && (size_t)n + size < sizeof line) {
    memcpy(line + n, data, size);
    line[n + size] = '\0';
  }
  report(f, line);
}

static void on_missing(void* user, skr_status status, const void* data, size_t size,
                       uint64_t version) {
  (void)version;
  report_data((files*)user, "missing", status, data, size);
}

static void on_removed(void* user, skr_status status, const void* data, size_t size,
                       uint64_t version) {
  files* f = (files*)user;
  char line[64];
  (void)data;
  (void)size;
  (void)version;
  snprintf(line, sizeof line, "removed:%d", (int)status);
  report(f, line);
  f->host->blob_get(f->ctx, f->files, "a/hello.txt", 1024, on_missing, f);
}

static void on_list(void* user, skr_status status, const void* data, size_t size,
                    uint64_t version) {
  files* f = (files*)user;
  (void)version;
  report_data(f, "list", status, data, size);
  f->host->blob_do(f->ctx, f->files, SKR_BLOB_REMOVE, "a/hello.txt", on_removed, f);
}

static void on_get(void* user, skr_status status, const void* data, size_t size, uint64_t version) {
  files* f = (files*)user;
  (void)version;
  report_data(f, "get", status, data, size);
  f->host->blob_list(f->ctx, f->files, "a", on_list, f);
}

static void on_put(void* user, skr_status status, const void* data, size_t size, uint64_t version) {
  files* f = (files*)user;
  char line[64];
  (void)data;
  (void)size;
  snprintf(line, sizeof line, "put:%d:%s", (int)status, version != 0 ? "versioned" : "none");
  report(f, line);
  f->host->blob_get(f->ctx, f->files, "a/hello.txt", 1024, on_get, f);
}

static void on_change(void* user, uint16_t chan_id, const void* data, size_t size) {
  (void)chan_id;
  report_data((files*)user, "event", SKR_OK, data, size);
}

static void never(void* user, skr_status status, const void* data, size_t size, uint64_t version) {
  (void)status;
  (void)data;
  (void)size;
  (void)version;
  report((files*)user, "never:called");
}

static void on_listener(void* user, uint16_t chan_id, int first) {
  files* f = (files*)user;
  char line[64];
  static const char kHello[] = "hello from a module";
  (void)chan_id;
  if (!first) return;
  snprintf(line, sizeof line, "bad:%d",
           (int)f->host->blob_get(f->ctx, f->files, "../x", 1024, never, f));
  report(f, line);
  f->host->blob_put(f->ctx, f->files, "a/hello.txt", kHello, sizeof kHello - 1, on_put, f);
}

static skr_status files_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  files* f = (files*)calloc(1, sizeof(files));
  if (f == NULL) return SKR_ERR_NO_MEMORY;
  if (host->abi_minor < 4) {
    host->set_error(ctx, "needs a hub with plugin ABI 1.4");
    free(f);
    return SKR_ERR_UNSUPPORTED;
  }
  f->host = host;
  f->ctx = ctx;
  *out = f;
  return SKR_OK;
}

static skr_status files_start(void* instance) {
  files* f = (files*)instance;
  char name[160];
  skr_sub_handle sub = 0;
  skr_status s = f->host->channel_create(f->ctx, "files", SKR_CHANNEL_BLOB, "", NULL, NULL, NULL, f,
                                         &f->files);
  if (s != SKR_OK) return s;
  s = f->host->channel_create(f->ctx, "report", SKR_CHANNEL_STREAMING, "text/plain", NULL,
                              on_listener, NULL, f, &f->report);
  if (s != SKR_OK) return s;
  snprintf(name, sizeof name, "%s.files", f->host->module_name(f->ctx));
  return f->host->subscribe(f->ctx, name, on_change, f, &sub);
}

static void files_fini(void* instance) {
  free(instance);
}

static const skr_module_descriptor k_descriptor = {sizeof(skr_module_descriptor),
                                                   SKR_PLUGIN_ABI_MAJOR,
                                                   SKR_PLUGIN_ABI_MINOR,
                                                   "blob_files",
                                                   "1.0.0",
                                                   "test: blob channel calls from C",
                                                   0,
                                                   files_init,
                                                   files_start,
                                                   NULL,
                                                   files_fini,
                                                   NULL,
                                                   0,
                                                   NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return &k_descriptor;
}
