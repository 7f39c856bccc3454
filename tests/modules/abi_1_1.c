/* A module built for ABI 1.1: its descriptor ends after fini (no config_keys), as modules built
 * before 1.2 do. It must still load, with its config unchecked. Logs ABI11-INIT with what it
 * reads. */
#include <skrobot/plugin.h>

#include <stdio.h>

/* skr_module_descriptor as ABI 1.1 declared it. */
typedef struct descriptor_1_1 {
  uint32_t struct_size;
  uint16_t abi_major;
  uint16_t abi_minor;
  const char* name;
  const char* version;
  const char* description;
  uint64_t flags;
  skr_status (*init)(const skr_host_api* host, skr_module_ctx* ctx, void** instance_out);
  skr_status (*start)(void* instance);
  skr_status (*stop)(void* instance);
  void (*fini)(void* instance);
} descriptor_1_1;

static skr_status old_init(const skr_host_api* host, skr_module_ctx* ctx, void** out) {
  char line[200];
  snprintf(line, sizeof line, "count=%lld anything=%s json=%s",
           (long long)host->config_int(ctx, "count", 7),
           host->config_string(ctx, "anything", "none"), host->config_json(ctx));
  host->log(ctx, SKR_LOG_INFO, "ABI11-INIT", line);
  *out = NULL;
  return SKR_OK;
}

static const descriptor_1_1 k_descriptor = {sizeof(descriptor_1_1),
                                            1,
                                            1,
                                            "abi_1_1",
                                            "1.1.0",
                                            "a module built for ABI 1.1",
                                            0,
                                            old_init,
                                            NULL,
                                            NULL,
                                            NULL};

SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void) {
  return (const skr_module_descriptor*)(const void*)&k_descriptor;
}
