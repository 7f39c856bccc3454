/* SPDX-License-Identifier: Apache-2.0 */
/* The skrobot module ABI: the only seam between the hub and a module (an internal satellite
 * loaded with dlopen). Plain C, usable from C and C++. No C++ type, exception or class crosses it.
 *
 * A module exports one symbol, skrobot_module_entry, returning a size-prefixed, versioned
 * descriptor with its lifecycle functions. The hub passes its services in at init as a
 * size-prefixed table of function pointers (skr_host_api); a module links nothing from the hub
 * (modules are built with -Wl,--no-undefined).
 *
 * Lifecycle, in order (T = the module's loop thread: the hub's main loop thread, or the module's
 * own loop thread when it asked for one with SKR_MODULE_WANTS_OWN_THREAD or "own_thread" in the
 * config):
 *
 *   step        thread  may block                idempotent  on failure
 *   entry       main    no                       yes         null/short descriptor or other ABI:
 *                                                            MODULE-DESCRIPTOR / MODULE-ABI
 *   init        T       briefly (read config)    no (once)   MODULE-INIT; registrations removed;
 *                                                            fini NOT called; library closed
 *   start       T       briefly                  no (once)   MODULE-START; registrations removed;
 *                                                            stop NOT called; fini called
 *   tick, post  T       never (use a worker)     -           -
 *   stop        T       only to join its workers yes         MODULE-STOP; the cleanup goes on
 *   fini        T       only to free             no (once)   cannot fail
 *
 * - The entry symbol is called once after dlopen; it must only return a pointer to static data.
 * - Between entry and init, a module that declares its config keys (ABI 1.2) has its config
 *   checked: on any problem it is never inited (MODULE-CONFIG), its library is closed.
 * - init runs in config order, after every module was loaded; start runs after every module was
 *   inited, in config order; stop runs in the reverse order of start; fini in reverse load order,
 *   then the library is closed. A module that failed a step never sees a later one.
 * - Ticks only run between a successful start and stop, even if registered during init.
 * - Every registration (tick handlers, posted work that has not run yet) is owned by the host:
 *   after stop returns (or after init/start failed) the host removes what is left. Posted work
 *   that is discarded has its `cancel` called instead of `fn`, so the module can free it.
 * - fini must accept an instance that was never started (start failed, or the hub quit early).
 */
#ifndef SKROBOT_PLUGIN_H
#define SKROBOT_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Major: incompatible changes; the host refuses another major. Minor: additions at the end of
 * the structs or in reserved slots; the host refuses a module built for a newer minor. Either is
 * refused on the descriptor's first 8 bytes (struct_size, abi_major, abi_minor) alone: the host
 * reads nothing else of it, so these three fields keep their place in every future major. */
#define SKR_PLUGIN_ABI_MAJOR 1
#define SKR_PLUGIN_ABI_MINOR 11

#define SKR_EXPORT __attribute__((visibility("default")))
#define SKR_MODULE_ENTRY_SYMBOL "skrobot_module_entry"

/* Status of every call that can fail. 0 is success; a module may return any of these. */
typedef enum skr_status {
  SKR_OK = 0,
  SKR_ERR_INVALID_ARGUMENT = 1,   /* a null pointer, an unknown enum value */
  SKR_ERR_NOT_FOUND = 2,          /* unknown handle or key */
  SKR_ERR_FAILED = 3,             /* the operation failed; see the message set with set_error */
  SKR_ERR_EXCEPTION = 4,          /* a C++ exception was caught at the seam */
  SKR_ERR_NOT_ON_LOOP_THREAD = 5, /* a loop-thread-only call came from another thread */
  SKR_ERR_BAD_STATE = 6,          /* not allowed in this lifecycle step (e.g. post after stop) */
  SKR_ERR_NO_MEMORY = 7,
  SKR_ERR_UNSUPPORTED = 8, /* not provided by this host's ABI version */
  SKR_ERR_CONFIG = 9,      /* the module's config is invalid */
  SKR_STATUS_FORCE_32BIT = 0x7fffffff
} skr_status;

typedef enum skr_log_level {
  SKR_LOG_DEBUG = 0,
  SKR_LOG_INFO = 1,
  SKR_LOG_WARN = 2,
  SKR_LOG_ERROR = 3
} skr_log_level;

typedef enum skr_tick {
  SKR_TICK_FAST = 0,   /* every fast interval: the loop's resolution */
  SKR_TICK_SLOW = 1,   /* every slow interval (>= fast) */
  SKR_TICK_ONE_SEC = 2 /* every second */
} skr_tick;

/* Handle of a tick registration; 0 is never a valid handle. */
typedef uint64_t skr_tick_handle;

/* Opaque per-module context owned by the host, valid from init until fini returns. */
typedef struct skr_module_ctx skr_module_ctx;

/* Timing of the module's loop. Host-owned, valid until fini. */
typedef struct skr_loop_info {
  uint32_t struct_size;     /* sizeof(skr_loop_info) of the host; fields are only appended */
  uint32_t own_thread;      /* 1 when the module runs on a loop thread of its own */
  int64_t fast_interval_ns; /* FastTick period */
  int64_t slow_interval_ns; /* SlowTick period */
  int32_t timing_mode;      /* 0 coarse, 1 pseudo-realtime, 2 socket-driven, 3 none */
  uint32_t reserved0;
  const char* loop_name;
} skr_loop_info;

typedef void (*skr_callback)(void* user);

/* --- FlowNetwork channels (ABI 1.1) --- */
typedef enum skr_channel_kind {
  SKR_CHANNEL_STREAMING = 1, /* one publisher (the owner), many subscribers */
  SKR_CHANNEL_SERVICE = 2,   /* requests to the owner, one response each */
  SKR_CHANNEL_BLOB = 3,      /* files kept by the hub (ABI 1.4; docs/blob-channels.md) */
  SKR_CHANNEL_SYNC = 4       /* a sync source: pulses, no data (ABI 1.5; docs/sync-pulse.md) */
} skr_channel_kind;

/* Handle of a subscription; 0 is never a valid handle. */
typedef uint64_t skr_sub_handle;

/* Data on a subscribed channel: `data` is the publisher's buffer, valid only during the call
 * (no copy is made for modules). */
typedef void (*skr_data_fn)(void* user, uint16_t chan_id, const void* data, size_t size);
/* An owned streaming channel got its first subscriber (first = 1) or lost its last (first = 0):
 * start or stop producing. */
typedef void (*skr_subscribers_fn)(void* user, uint16_t chan_id, int first);
/* A request to an owned service channel. Answer with service_respond(request, ...), now or later.
 * Strings are valid during the call; `value_json` is the request's value as JSON text. */
typedef void (*skr_request_fn)(void* user, uint16_t chan_id, uint64_t request, const char* command,
                               const char* requester, const char* value_json);
/* The answer to service_request: status SKR_OK and the owner's value, or an error status with a
 * JSON string explaining it (owner gone, no such channel, overflow). */
typedef void (*skr_response_fn)(void* user, uint16_t chan_id, uint32_t tag, skr_status status,
                                const char* value_json);

/* The answer to db_sync (ABI 1.3): SKR_OK once the changes are on disk; SKR_ERR_FAILED when
 * writing them failed; SKR_ERR_BAD_STATE when the module stopped first (then during its stop). */
typedef void (*skr_done_fn)(void* user, skr_status status);

/* --- blob channels (ABI 1.4) --- */
typedef enum skr_blob_op {
  SKR_BLOB_MKDIR = 1, /* makes a directory (and missing parents) */
  SKR_BLOB_RMDIR = 2, /* removes an empty directory */
  SKR_BLOB_REMOVE = 3 /* removes a file */
} skr_blob_op;
/* The answer to a blob call, once, on the loop thread: status SKR_OK and, for blob_get, the
 * file's bytes (valid during the call only), for blob_list, the entries as JSON text (a list of
 * {"name", "dir", "size", "mtime_ns", "version"}); `version` is the file's version (blob_get,
 * blob_put). An error status otherwise, with a message as data (NUL-terminated):
 * SKR_ERR_NOT_FOUND (no such file or channel), SKR_ERR_INVALID_ARGUMENT (a bad path, not the
 * owner), SKR_ERR_FAILED (a quota, a disk failure); SKR_ERR_BAD_STATE when the module stopped
 * first (then during its stop). */
typedef void (*skr_blob_fn)(void* user, skr_status status, const void* data, size_t size,
                            uint64_t version);

/* --- the sync pulse (ABI 1.5) --- */
/* A pulse of a followed source, on the loop thread: the module's tick for it. `seq` counts the
 * source's pulses; `source_time_ns` is the source's monotonic clock when it pulsed; `dropped`
 * is the number of pulses dropped for this module since the last one it got, because it had not
 * finished the previous one. The pulse is finished when fn returns, or, with
 * SKR_SYNC_DONE_LATER, when the module calls sync_done (e.g. once its worker is through). */
typedef void (*skr_sync_fn)(void* user, uint16_t chan_id, uint64_t seq, uint64_t source_time_ns,
                            uint32_t dropped);
/* Flags of sync_follow. */
#define SKR_SYNC_DONE_LATER ((uint32_t)1 << 0) /* the module calls sync_done for each pulse */

/* --- watching channels and databases (ABI 1.6) --- */
/* A channel was added (added = 1) or removed (added = 0): its full name, kind and mime type,
 * valid during the call. Local channels and those of linked hubs ("arm/guest.camera") alike. */
typedef void (*skr_channel_fn)(void* user, uint16_t chan_id, const char* name,
                               skr_channel_kind kind, const char* mime, int added);
/* A change of a watched database (`db`, valid during the call like the rest): `key` now holds
 * `value_json`; value_json NULL: `key` was removed; key NULL (and value_json NULL): the database
 * was cleared. */
typedef void (*skr_db_change_fn)(void* user, const char* db, const char* key,
                                 const char* value_json);

/* --- physical mode (ABI 1.7; docs/physical-mode.md) --- */
/* Path kinds a streaming channel may offer its subscribers besides the hub's relay. */
#define SKR_PATH_DIRECT ((uint32_t)1 << 0) /* a Unix socket of the hub's, one per module */
#define SKR_PATH_SHM ((uint32_t)1 << 1)    /* a ring of slots in shared memory (a sealed memfd) */

/* What channel_paths offers. Zeroed fields take the defaults. */
typedef struct skr_path_options {
  uint32_t struct_size;  /* sizeof(skr_path_options) the module was built with */
  uint32_t kinds;        /* SKR_PATH_DIRECT | SKR_PATH_SHM, at least one */
  uint32_t ring_slots;   /* shared memory: slots in the ring (0: 4) */
  uint32_t ring_readers; /* shared memory: readers at once, at most 64 (0: 4) */
  uint64_t slot_bytes;   /* shared memory: the largest message (0: 1 MB) */
} skr_path_options;

/* --- WebSocket endpoints on the hub's web port (ABI 1.8; docs/plugins.md) --- */
/* One browser's (or any client's) connection to an endpoint: unique for the hub's life. */
typedef uint64_t skr_ws_conn;
/* What an endpoint hears, on the module's loop thread. Strings and data are valid during the call
 * only. The module may call ws_send and ws_close from any of them. */
typedef struct skr_ws_events {
  uint32_t struct_size; /* sizeof(skr_ws_events) the module was built with */
  /* A client upgraded to the endpoint (its path, its subprotocol, an allowed Origin). `peer` is
   * where it came from ("ws:127.0.0.1"). */
  void (*opened)(void* user, skr_ws_conn conn, const char* peer);
  /* One whole message, text (text = 1; not checked for UTF-8) or binary, of at most the
   * endpoint's max_message_bytes (a longer one closes that connection with 1009 first). */
  void (*message)(void* user, skr_ws_conn conn, int text, const void* data, size_t size);
  /* The connection is gone (the client closed it, it broke, or ws_close): `why` in words. No
   * call for `conn` follows. */
  void (*closed)(void* user, skr_ws_conn conn, const char* why);
} skr_ws_events;

/* Host services, passed to init. Valid until fini returns. Check struct_size / abi_minor before
 * using a function added after 1.0. Thread rules: "any" = callable from any thread; "loop" = only
 * on the module's loop thread (returns SKR_ERR_NOT_ON_LOOP_THREAD otherwise). */
typedef struct skr_host_api {
  uint32_t struct_size; /* sizeof(skr_host_api) of the host */
  uint16_t abi_major;   /* the host's ABI */
  uint16_t abi_minor;

  /* --- logging (any) --- */
  /* One line, source "mod.<name>", with a stable `tag` (may be NULL or ""). */
  void (*log)(skr_module_ctx* ctx, skr_log_level level, const char* tag, const char* message);
  /* Non-zero when lines of `level` are written; skip formatting otherwise. */
  int (*log_enabled)(skr_module_ctx* ctx, skr_log_level level);

  /* --- the module's config object (any; read-only) --- */
  /* `key` is a member of the module's "config" object. A missing key gives the default; a key of
   * the wrong type gives the default and logs MODULE-CONFIG (a warning). With declared keys
   * (ABI 1.2) the declared defaults are present, config_has is true for them, and a wrong type
   * never reaches init. Strings are host-owned, valid until fini. */
  const char* (*config_string)(skr_module_ctx* ctx, const char* key, const char* default_value);
  int64_t (*config_int)(skr_module_ctx* ctx, const char* key, int64_t default_value);
  double (*config_double)(skr_module_ctx* ctx, const char* key, double default_value);
  int (*config_bool)(skr_module_ctx* ctx, const char* key, int default_value);
  int (*config_has)(skr_module_ctx* ctx, const char* key);
  /* The whole config object as JSON text, for complex values. Host-owned, valid until fini. */
  const char* (*config_json)(skr_module_ctx* ctx);
  /* Reports a config problem: logs "MODULE-CONFIG $.modules[N].config.<key>: <reason>". Init
   * should then fail with SKR_ERR_CONFIG; the host quotes the problem if no error was set. */
  void (*config_error)(skr_module_ctx* ctx, const char* key, const char* reason);

  /* --- ticks (loop) --- */
  /* Calls fn(user) on every tick of `which` while the module is started (from start until stop),
   * in registration order. `user` stays the module's. Allowed from init until stop returns. */
  skr_status (*tick_add)(skr_module_ctx* ctx, skr_tick which, skr_callback fn, void* user,
                         skr_tick_handle* handle_out);
  /* After it returns, fn is never called again. SKR_ERR_NOT_FOUND for an unknown handle or one
   * the host already removed at stop. */
  skr_status (*tick_remove)(skr_module_ctx* ctx, skr_tick_handle handle);

  /* --- work from other threads (any) --- */
  /* Thread-safe; wakes the loop. Exactly one of fn(user) (on the loop thread, at a later pulse,
   * in post order) or cancel(user) (when the module stops before it ran; cancel may be NULL) is
   * called. Allowed from init until stop returns; otherwise SKR_ERR_BAD_STATE and neither is
   * called (the caller still owns `user`). */
  skr_status (*post)(skr_module_ctx* ctx, skr_callback fn, skr_callback cancel, void* user);

  /* --- time and loop (any) --- */
  int64_t (*now_ns)(void); /* monotonic clock, nanoseconds */
  const skr_loop_info* (*loop_info)(skr_module_ctx* ctx);

  /* --- errors --- */
  /* Explains why init/start/stop fails; the host logs it. Call on the loop thread during that
   * step. The text is copied. */
  void (*set_error)(skr_module_ctx* ctx, const char* message);
  /* Static text for a status; never NULL. */
  const char* (*strerror)(skr_status status);
  /* The module's name in the config (its log source is "mod.<name>"). */
  const char* (*module_name)(skr_module_ctx* ctx);

  /* --- FlowNetwork channels and databases (ABI 1.1; loop). Allowed from start until stop
   * returns; the host removes the module's channels and subscriptions when it stops. Values
   * cross the seam as JSON text (docs/pair-databases.md gives the mapping).
   * A module on its own thread (ABI 1.10; before, SKR_ERR_NOT_ON_LOOP_THREAD): the call runs on
   * the hub's main loop while the module's thread waits, and its callbacks run on the module's
   * thread with copies of their data, never for a subscription, channel or watch it ended
   * before. db_sync, db_watch, the blob, sync_follow/unfollow/done, channel_paths and
   * publish_begin/commit calls still answer SKR_ERR_NOT_ON_LOOP_THREAD there. --- */
  /* Creates "<module name>.<short_name>" with `props_json` (a JSON object, or NULL) as its
   * database. Callbacks may be NULL. Other satellites see it at once. */
  skr_status (*channel_create)(skr_module_ctx* ctx, const char* short_name, skr_channel_kind kind,
                               const char* mime, const char* props_json,
                               skr_subscribers_fn on_subscribers, skr_request_fn on_request,
                               void* user, uint16_t* chan_id_out);
  skr_status (*channel_remove)(skr_module_ctx* ctx, uint16_t chan_id);
  /* SKR_ERR_NOT_FOUND when no channel has that full name now. */
  skr_status (*channel_find)(skr_module_ctx* ctx, const char* name, uint16_t* chan_id_out);
  /* Publishes on an owned streaming channel; other modules get `data` without a copy. */
  skr_status (*publish)(skr_module_ctx* ctx, uint16_t chan_id, const void* data, size_t size);
  /* Subscribes to a streaming channel by full name. If it does not exist yet the subscription
   * waits for it, and it follows the channel when it is removed and created again. */
  skr_status (*subscribe)(skr_module_ctx* ctx, const char* name, skr_data_fn fn, void* user,
                          skr_sub_handle* handle_out);
  skr_status (*unsubscribe)(skr_module_ctx* ctx, skr_sub_handle handle);
  /* A request to a service channel; fn(user, ...) gets the answer with `tag` (fn may be NULL). */
  skr_status (*service_request)(skr_module_ctx* ctx, uint16_t chan_id, uint32_t tag,
                                const char* command, const char* value_json, skr_response_fn fn,
                                void* user);
  skr_status (*service_respond)(skr_module_ctx* ctx, uint16_t chan_id, uint64_t request,
                                const char* value_json);
  /* A variable as JSON text into buf (NUL-terminated). SKR_ERR_NOT_FOUND for no such database or
   * key; SKR_ERR_NO_MEMORY when cap is too small, with *len_out the size needed (NUL included). */
  skr_status (*db_get)(skr_module_ctx* ctx, const char* db, const char* key, char* buf, size_t cap,
                       size_t* len_out);
  /* Sets a variable of a database the module may write (named ones, its own user database
   * "<module name>", its channels' databases). */
  skr_status (*db_set)(skr_module_ctx* ctx, const char* db, const char* key,
                       const char* value_json);

  /* --- durable databases (ABI 1.3; loop, as the calls above) --- */
  /* A barrier: fn(user, status) is called once, on the loop thread, when every database change
   * the hub made before this call (this module's db_set calls among them) is on disk, whatever
   * the hub's durability policy (docs/pair-databases.md). */
  skr_status (*db_sync)(skr_module_ctx* ctx, skr_done_fn fn, void* user);

  /* --- blob channels (ABI 1.4; loop, as the calls above) --- channel_create with
   * SKR_CHANNEL_BLOB makes the module's blob channel "<module name>.<short_name>", or gives the
   * existing one back with its files: unlike other channels it outlives the module's stop. Reads
   * are for any blob channel the module may subscribe to; writes for its own. Each call checks
   * the channel and the path at once (an error status, and fn is never called) and answers
   * through fn(user, ...) on the loop thread; the disk work runs on the hub's blob thread.
   * subscribe() to a blob channel gets its changes as data: a JSON object {"change":
   * "written"|"removed"|"dir_added"|"dir_removed", "path", "size", "version"}. */
  /* The whole current version of `path`, if it has at most max_bytes. */
  skr_status (*blob_get)(skr_module_ctx* ctx, uint16_t chan_id, const char* path,
                         uint64_t max_bytes, skr_blob_fn fn, void* user);
  /* Replaces or creates `path` (missing directories are made) with the `size` bytes at `data`
   * (copied), atomically: readers see the old file or the new one, never a mix. */
  skr_status (*blob_put)(skr_module_ctx* ctx, uint16_t chan_id, const char* path, const void* data,
                         size_t size, skr_blob_fn fn, void* user);
  /* The entries of the directory `dir` ("" is the root). */
  skr_status (*blob_list)(skr_module_ctx* ctx, uint16_t chan_id, const char* dir, skr_blob_fn fn,
                          void* user);
  skr_status (*blob_do)(skr_module_ctx* ctx, uint16_t chan_id, skr_blob_op op, const char* path,
                        skr_blob_fn fn, void* user);

  /* --- the sync pulse (ABI 1.5; loop, as the calls above; docs/sync-pulse.md) ---
   * channel_create with SKR_CHANNEL_SYNC makes a source "<module name>.<short_name>" that other
   * modules and satellites may follow. */
  /* Pulses an owned source: each follower that finished the previous pulse gets this one. */
  skr_status (*sync_pulse)(skr_module_ctx* ctx, uint16_t chan_id);
  /* Follows the source with that full name, every `every`th pulse (0 and 1: each), calling
   * fn(user, ...) on each. Like subscribe it waits for a source that does not exist yet and
   * follows it again when it is re-created. One follow per source and module: another call for
   * the same name is SKR_ERR_INVALID_ARGUMENT. `flags`: SKR_SYNC_*. */
  skr_status (*sync_follow)(skr_module_ctx* ctx, const char* name, uint32_t every, uint32_t flags,
                            skr_sync_fn fn, void* user, skr_sub_handle* handle_out);
  /* After it returns, fn is never called again. */
  skr_status (*sync_unfollow)(skr_module_ctx* ctx, skr_sub_handle handle);
  /* With SKR_SYNC_DONE_LATER: the module's tick for pulse `seq` is over, the next pulse may come.
   * A stale seq is ignored. */
  skr_status (*sync_done)(skr_module_ctx* ctx, skr_sub_handle handle, uint64_t seq);

  /* --- watching, and the hub's name (ABI 1.6; loop, as the calls above, but hub_name: any) ---
   */
  /* This hub's name in a linked network (its config's hub_name, or the host's name). */
  const char* (*hub_name)(skr_module_ctx* ctx);
  /* Calls fn(user, ...) for every channel there is now (added = 1), during this call, then for
   * each channel added or removed until channel_unwatch. */
  skr_status (*channel_watch)(skr_module_ctx* ctx, skr_channel_fn fn, void* user,
                              skr_sub_handle* handle_out);
  skr_status (*channel_unwatch)(skr_module_ctx* ctx, skr_sub_handle handle);
  /* Watches a database the module may read (SKR_ERR_INVALID_ARGUMENT otherwise; it need not
   * exist yet): fn(user, ...) for every pair it holds now, during this call, then right after
   * each change, whoever made it (the module's own db_set calls too). fn must not change that
   * database itself; post the change instead. */
  skr_status (*db_watch)(skr_module_ctx* ctx, const char* db, skr_db_change_fn fn, void* user,
                         skr_sub_handle* handle_out);
  skr_status (*db_unwatch)(skr_module_ctx* ctx, skr_sub_handle handle);
  /* Removes a variable, where db_set may write. SKR_ERR_NOT_FOUND: no such database or key. */
  skr_status (*db_remove)(skr_module_ctx* ctx, const char* db, const char* key);

  /* --- physical mode (ABI 1.7; loop, as the calls above; docs/physical-mode.md) ---
   * The hub serves an owned streaming channel's subscribers that ask for a path (satellites of
   * this machine) directly: through shared memory, or a socket of its own, instead of relaying
   * each message; plain publish keeps working (copied into a slot and onto direct sockets, and
   * relayed only while some subscriber is relayed). The paths go with the channel. */
  /* Offers paths for `chan_id` (owned, streaming). Call once, after channel_create.
   * SKR_ERR_NOT_FOUND: not a channel of this module; SKR_ERR_INVALID_ARGUMENT: not streaming,
   * no kind, or offered already; SKR_ERR_FAILED: none can be served (logged; a ring that cannot
   * be made leaves direct). */
  skr_status (*channel_paths)(skr_module_ctx* ctx, uint16_t chan_id,
                              const skr_path_options* options);
  /* A shared-memory slot to fill in place: *slot_out (*capacity_out bytes, slot_bytes), valid
   * until publish_commit or the next publish_begin or publish on this channel. SKR_ERR_NOT_FOUND:
   * the channel offers no shared memory; SKR_ERR_BAD_STATE: every slot is being read (publish a
   * copy instead, or drop the message). */
  skr_status (*publish_begin)(skr_module_ctx* ctx, uint16_t chan_id, void** slot_out,
                              size_t* capacity_out);
  /* Publishes the first `size` bytes of the slot publish_begin gave: readers of the ring get it
   * in place, direct subscribers and relayed ones a copy. `capture_ns`: the message's own time
   * (e.g. a frame's capture, monotonic clock), or 0. SKR_ERR_BAD_STATE: no publish_begin before;
   * SKR_ERR_INVALID_ARGUMENT: size over the capacity. */
  skr_status (*publish_commit)(skr_module_ctx* ctx, uint16_t chan_id, size_t size,
                               int64_t capture_ns);

  /* --- WebSocket endpoints on the hub's web port (ABI 1.8; loop, as the calls above) ---
   * The hub's web port (server.web) upgrades GET `path` offering `subprotocol`, from a page of an
   * allowed Origin (server.web.origins; the port's Host check first), to a connection of whole
   * messages for this module: browsers reach a module on the port that serves the pages and
   * FlowProtocol (/flow), with TLS when the port has it. The endpoint goes with the module. */
  /* Serves `path` ("/" then plain segments; not /flow or /skrobot/token) with `subprotocol` (a
   * token, required of the client): messages of at most `max_message_bytes` (> 0) each; at most
   * `max_queued_bytes` (0: 8 MiB) waiting to be sent to one client. *handle_out for ws_unserve.
   * SKR_ERR_UNSUPPORTED: the hub has no web port; SKR_ERR_INVALID_ARGUMENT: a bad path or
   * subprotocol, or a path served already. */
  skr_status (*ws_serve)(skr_module_ctx* ctx, const char* path, const char* subprotocol,
                         size_t max_message_bytes, size_t max_queued_bytes,
                         const skr_ws_events* events, void* user, skr_sub_handle* handle_out);
  /* Stops serving and drops its connections (close 1001), with no more events. */
  skr_status (*ws_unserve)(skr_module_ctx* ctx, skr_sub_handle handle);
  /* Queues one message for `conn` (copied). Beyond max_queued_bytes the oldest `droppable`
   * messages waiting go first; a message that is not droppable pushes them out and is dropped
   * last. SKR_ERR_NOT_FOUND: no such connection (it closed). */
  skr_status (*ws_send)(skr_module_ctx* ctx, skr_ws_conn conn, int text, const void* data,
                        size_t size, int droppable);
  /* Closes `conn` with a close code (RFC 6455: 1000..1003, 1007..1011, or 3000..4999 of the
   * module's own) and a reason; `closed` follows. SKR_ERR_NOT_FOUND: no such connection;
   * SKR_ERR_INVALID_ARGUMENT: a code that may not be sent. */
  skr_status (*ws_close)(skr_module_ctx* ctx, skr_ws_conn conn, uint16_t code, const char* reason);

  /* 1.8 spent the last reserved slot: later minors add their members here, at the end (the
   * table's struct_size says which a host has). */

  /* --- retained messages (ABI 1.9; loop, as the calls above; docs/plugins.md "Retained
   * messages") ---
   * A streaming channel keeps, per key, the last message its owner published with
   * publish_retained; each subscriber that comes later gets every one kept, oldest first, when it
   * subscribes (a module's during its subscribe call), before any live message: a latched topic
   * (ROS 2's transient_local: /tf_static, a map), a robot's description, a last known state. */
  /* Publishes like publish, and keeps `data` as the message retained under `key` (1 to 255
   * bytes; it replaces the one kept under that key, and counts as the newest). At most 64 keys
   * and 16 MiB per channel: SKR_ERR_FAILED beyond them (nothing kept or sent; logged).
   * SKR_ERR_NOT_FOUND: no such channel; SKR_ERR_INVALID_ARGUMENT: not a streaming channel of
   * this module, or a key of another length. */
  skr_status (*publish_retained)(skr_module_ctx* ctx, uint16_t chan_id, const char* key,
                                 const void* data, size_t size);
  /* Forgets the message kept under `key`, or every one when `key` is NULL (subscribers that
   * have them keep them). SKR_ERR_NOT_FOUND: no such channel, or nothing kept under `key`;
   * SKR_ERR_INVALID_ARGUMENT: not a channel of this module. */
  skr_status (*retain_clear)(skr_module_ctx* ctx, uint16_t chan_id, const char* key);

  /* --- a module that cannot go on (ABI 1.10; any thread) ---
   * For what the module learns after start (a file it reads in the background is bad, a device
   * is gone for good): the host logs MODULE-FAILED with `reason` (NULL: a generic one), and soon
   * after, from the main loop, stops the module as at shutdown (stop, its registrations
   * removed, fini) and closes its library; the hub lists it with the modules that failed. Only
   * the first call counts; one made when the module is not running (any more) is ignored. A
   * step that fails (init, start) returns its status instead. */
  void (*fail)(skr_module_ctx* ctx, const char* reason);
} skr_host_api;

/* --- Declared config keys (ABI 1.2) ---
 * A module may declare every key of its "config" object in a static array (see config_keys in
 * skr_module_descriptor). The host then checks the config BEFORE init, and also for
 * `skrobot --check-config` without running the module: a key of the wrong type, out of range,
 * not among the choices, a required key missing, or a key the module does not declare is an
 * error, logged as "MODULE-CONFIG $.modules[N].config.<key>: <reason>", and the module is not
 * inited. The declared defaults are filled in: config_* and config_json see them as if the user
 * had written them. */
typedef enum skr_config_type {
  SKR_CONFIG_STRING = 1,
  SKR_CONFIG_INT = 2,    /* an integral number (10 and 10.0 both pass) */
  SKR_CONFIG_DOUBLE = 3, /* any number */
  SKR_CONFIG_BOOL = 4,
  SKR_CONFIG_ARRAY = 5,  /* any array; min/max bound its number of items; elements unchecked */
  SKR_CONFIG_OBJECT = 6, /* any object; its members are the module's to check */
  SKR_CONFIG_ANY = 7,    /* any value but null (e.g. a path or an index); the module checks it */
  SKR_CONFIG_TYPE_FORCE_32BIT = 0x7fffffff
} skr_config_type;

/* Flags of skr_config_key. */
#define SKR_CONFIG_REQUIRED ((uint32_t)1 << 0)  /* the key must be present (no default) */
#define SKR_CONFIG_MIN ((uint32_t)1 << 1)       /* `min` applies */
#define SKR_CONFIG_MAX ((uint32_t)1 << 2)       /* `max` applies */
#define SKR_CONFIG_NON_EMPTY ((uint32_t)1 << 3) /* a string must not be "" */

/* One key of a module's config. Static data of the module; all strings UTF-8. */
typedef struct skr_config_key {
  const char* key; /* a member name of the module's "config" object; required */
  skr_config_type type;
  uint32_t flags;           /* SKR_CONFIG_* */
  const char* default_text; /* the default, or NULL: none, the key stays absent when not given.
                               A string key's default is the plain string ("hello"); any other
                               type's is JSON text ("1000", "true", "[1, 2]") */
  double min;               /* inclusive bounds with SKR_CONFIG_MIN / SKR_CONFIG_MAX: of the */
  double max;               /* value (int, double), of the number of items (array) */
  const char* choices;      /* string: the allowed values separated by '|', or NULL: any */
  const char* description;  /* one line, for the module's config reference; may be NULL */
} skr_config_key;

/* Flags of skr_module_descriptor. Unknown flags are ignored. */
#define SKR_MODULE_WANTS_OWN_THREAD ((uint64_t)1 << 0) /* run on a loop thread of its own */

/* What skrobot_module_entry returns: static data, never freed. */
typedef struct skr_module_descriptor {
  uint32_t struct_size;    /* sizeof(skr_module_descriptor) the module was built with */
  uint16_t abi_major;      /* SKR_PLUGIN_ABI_MAJOR the module was built against */
  uint16_t abi_minor;      /* SKR_PLUGIN_ABI_MINOR the module was built against */
  const char* name;        /* required, e.g. "example" */
  const char* version;     /* the module's own version, e.g. "1.2.0"; may be NULL */
  const char* description; /* one line; may be NULL */
  uint64_t flags;          /* SKR_MODULE_* */

  /* Required. Reads config, creates the instance, may register ticks and post work. `host` and
   * `ctx` stay valid until fini returns; keep them. *instance_out (may stay NULL) is passed to
   * the other steps. On failure: call host->set_error, free everything, return non-OK. */
  skr_status (*init)(const skr_host_api* host, skr_module_ctx* ctx, void** instance_out);
  /* Optional. Starts producing (workers, ticks). On failure: undo what start did. */
  skr_status (*start)(void* instance);
  /* Optional. Stops producing and joins the module's own threads; must not post afterwards.
   * Idempotent: a second call is a no-op. */
  skr_status (*stop)(void* instance);
  /* Optional. Frees the instance. Last call into the module before dlclose. */
  void (*fini)(void* instance);

  /* --- ABI 1.2 (the host reads them only when struct_size covers them) --- */
  /* The keys of the module's config object, or NULL: the module declares nothing, the host
   * passes its config unchecked (ABI 1.1 behaviour). A non-NULL array with count 0 declares a
   * module that takes no config: any key is an error. Static data, read before init and by
   * `skrobot --check-config` without init. */
  const skr_config_key* config_keys;
  size_t config_key_count;

  /* --- ABI 1.11 (read only when struct_size covers it) --- */
  /* Optional. The module's config changed while it runs (a reload of the hub's config): the
   * config calls now read the new object, checked against the declared keys first and with
   * their defaults. Apply it in place and return SKR_OK (its channels and state stay), or return
   * non-OK (SKR_ERR_UNSUPPORTED: not this change) to be restarted with it instead. Called on
   * the module's loop thread, between start and stop. Strings the config calls returned before
   * stay valid until it returns, not after. NULL: always restarted. */
  skr_status (*reconfigure)(void* instance);
} skr_module_descriptor;

typedef const skr_module_descriptor* (*skr_module_entry_fn)(void);

/* The one symbol a module exports (C linkage, default visibility). */
SKR_EXPORT const skr_module_descriptor* skrobot_module_entry(void);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* SKROBOT_PLUGIN_H */
