/* SPDX-License-Identifier: Apache-2.0 */
/* A board's session with a hub over a byte line (docs/flow-protocol.md; the line: skr_line.h),
 * or over a transport of whole frames (UDP datagrams: skr_udp_link.h).
 *
 * C99, no heap, no stdio, no floats unless a float helper is called. Everything lives in one
 * skr_flow the user declares (static), its sizes set at compile time by the SKR_* settings below.
 * Single-threaded: every function is called from the sketch's loop (never from an interrupt), and
 * callbacks run inside skr_poll().
 *
 *   static skr_flow f;
 *   skr_init(&f, &io, "robot", "secret", "uno");
 *   int analog = skr_channel(&f, "analog", "application/x-u16le");
 *   skr_subscribe(&f, "guest.setpoint", on_setpoint, 0);
 *   loop: skr_poll(&f); skr_publish(&f, analog, bytes, 2);
 *
 * The session: LOGIN -> SESSION_LIMITS (SKR_RX_MAX, no broadcast events, a watch made of the
 * subscriptions' names) -> GO_ASYNC -> CHAN_ADD of every declared channel, one at a time (each
 * one's id learnt from the EV_CHAN_ADDED carrying its tag, and the next sent then) and SUBSCRIBE /
 * SYNC_FOLLOW when a watched channel's EV_CHAN_ADDED arrives. Lost sessions (REPLY_ERROR,
 * not_logged_in, no reply in time, a channel's EV_CHAN_ADDED lost, a silent hub) start again
 * from LOGIN after a back-off. A connected board sends TIME_PROBE every SKR_PROBE_MS:
 * the hub answers EV_TIME_PROBE on the flow, so a hub that says nothing for SKR_SILENCE_MS is gone.
 */
#ifndef SKR_FLOW_H
#define SKR_FLOW_H

#include "skr_line.h"

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* --- settings (define before including, or with -D) ------------------------------------------ */
#ifndef SKR_RX_MAX /* the largest frame the board accepts, its 4 length bytes included (>= 64) */
#define SKR_RX_MAX 160
#endif
#ifndef SKR_TX_MAX /* the largest frame the board sends, length bytes included */
#define SKR_TX_MAX 96
#endif
#ifndef SKR_MAX_CHANNELS /* streaming channels the board owns */
#define SKR_MAX_CHANNELS 2
#endif
#ifndef SKR_MAX_SERVICES /* service channels the board owns */
#define SKR_MAX_SERVICES 1
#endif
#ifndef SKR_MAX_SUBS /* subscriptions and sync sources followed */
#define SKR_MAX_SUBS 2
#endif
#ifndef SKR_REPLY_TIMEOUT_MS /* a login step unanswered this long starts again */
#define SKR_REPLY_TIMEOUT_MS 3000u
#endif
#ifndef SKR_PROBE_MS /* a connected board's TIME_PROBE period */
#define SKR_PROBE_MS 2000u
#endif
#ifndef SKR_SILENCE_MS /* nothing from the hub for this long: it is gone */
#define SKR_SILENCE_MS 7000u
#endif
#ifndef SKR_BACKOFF_MS /* the first wait before logging in again; doubles up to SKR_BACKOFF_MAX_MS \
                        */
#define SKR_BACKOFF_MS 500u
#endif
#ifndef SKR_BACKOFF_MAX_MS
#define SKR_BACKOFF_MAX_MS 8000u
#endif

/* The line buffers: a received frame with the line's version and CRC; a sent frame, encoded in
 * place (skr_line.h, SKR_LINE_INPLACE_LEAD). */
#define SKR_RX_BUF (SKR_RX_MAX + SKR_LINE_RX_EXTRA)
#define SKR_TX_BUF (SKR_TX_MAX + SKR_LINE_OVERHEAD(SKR_TX_MAX))
#define SKR_TX_LEAD SKR_LINE_INPLACE_LEAD(SKR_TX_MAX)

/* Results of the calls below: 0 is OK. */
typedef enum {
  SKR_OK = 0,
  SKR_OFFLINE,    /* not connected (or the channel has no id yet): nothing was sent */
  SKR_TOO_BIG,    /* the frame would exceed SKR_TX_MAX */
  SKR_FULL,       /* no room left in a table (SKR_MAX_*) */
  SKR_BAD_HANDLE, /* no such channel handle */
  SKR_BAD_NAME,   /* a name with a space, or empty */
  SKR_BUSY        /* called from a service handler, which owns the send buffer */
} skr_status;
const char* skr_strerror(skr_status s);

/* How the session reaches its line. read: one byte (0..255), or -1 when none is waiting; write:
 * the line's bytes. For a transport of whole frames (UDP), read is NULL: write then gets one whole
 * frame per call (no line framing) and frames come in through skr_input_frame(). */
typedef struct {
  void* ctx;
  int (*read)(void* ctx);
  void (*write)(void* ctx, const uint8_t* data, size_t n);
  uint32_t (*millis)(void* ctx); /* a millisecond clock; wraps at 2^32 */
} skr_io;

/* A value being written (a Variant, binary encoding: docs/flow-protocol.md "Values"); ok drops to
 * 0 when it does not fit, and the value is then sent as null. */
typedef struct {
  uint8_t* p;
  size_t cap, len;
  uint8_t ok;
} skr_out;

typedef struct skr_flow skr_flow;

/* Data of a subscribed channel: the payload (len bytes, valid during the call). */
typedef void (*skr_data_fn)(void* user, const uint8_t* payload, size_t len);
/* A service request: command (cmd_len bytes, not NUL-terminated) and its value (a binary Variant,
 * read it with skr_value_*). Write the answer into `answer` with skr_put_*; nothing: null. */
typedef void (*skr_service_fn)(void* user, const char* cmd, size_t cmd_len, const uint8_t* value,
                               size_t value_len, skr_out* answer);
/* A sync pulse (seq 1, 2, ...; dropped: pulses lost since the last one). SYNC_DONE is sent when
 * the callback returns. */
typedef void (*skr_pulse_fn)(void* user, uint32_t seq, uint32_t dropped);
/* The answer to skr_var_get: the value (a binary Variant, len bytes, valid during the call; read
 * it with skr_value_*), or value 0 when the read failed (no such key or database, no right). */
typedef void (*skr_value_fn)(void* user, const uint8_t* value, size_t len);

typedef struct {
  skr_line_stats line;   /* the line's own counters (bad CRC, framing, too long) */
  uint32_t frames_bad;   /* frames shorter or longer than their layout, dropped */
  uint32_t errors;       /* REPLY_ERROR and EV_ERROR received */
  uint32_t logins;       /* sessions started (the first login included) */
  uint32_t sent_dropped; /* publishes and answers not sent (offline, too big) */
  uint16_t last_error;   /* the last error code the hub sent (SKR_ERROR_*) */
} skr_stats;

/* --- the state (treat as opaque) ------------------------------------------------------------ */
typedef struct {
  const char* name; /* short name */
  const char* mime;
  uint16_t id;
} skr_chan;
typedef struct {
  const char* name;
  skr_service_fn fn;
  void* user;
  uint16_t id;
} skr_service;
typedef struct {
  const char* name; /* full name */
  union {
    skr_data_fn data;   /* kind SKR_KIND_STREAMING */
    skr_pulse_fn pulse; /* kind SKR_KIND_SYNC */
  } fn;
  void* user;
  uint16_t id;
  uint8_t kind; /* SKR_KIND_STREAMING or SKR_KIND_SYNC */
} skr_sub;

struct skr_flow {
  skr_io io;
  const char *user, *password, *client;
  uint8_t state;
  uint8_t in_handler;
  uint16_t backoff_ms;
  uint32_t due_ms;   /* when the current wait ends (a login step, the back-off, a CHAN_ADD) */
  uint32_t heard_ms; /* when the hub last sent a frame */
  uint32_t probe_ms; /* when the last TIME_PROBE went */
  uint8_t n_chans, n_services, n_subs;
  uint8_t adding; /* the channel (then service) whose CHAN_ADD waits for its answer; 0xFF none */
  skr_chan chans[SKR_MAX_CHANNELS];
#if SKR_MAX_SERVICES > 0
  skr_service services[SKR_MAX_SERVICES];
#endif
  skr_sub subs[SKR_MAX_SUBS];
  skr_value_fn read_fn; /* the pending skr_var_get, 0 when none */
  void* read_user;
  uint8_t read_tag; /* its tag's low byte */
  skr_stats stats;
  skr_line_rx rx;
  uint8_t rx_buf[SKR_RX_BUF];
  uint8_t tx_buf[SKR_TX_BUF];
};

/* --- the API -------------------------------------------------------------------------------- */
/* Strings are the caller's and must stay (string literals). Logging in starts at the first
 * skr_poll(). */
void skr_init(skr_flow* f, const skr_io* io, const char* user, const char* password,
              const char* client_name);
/* Declares a streaming channel <user>.<short_name>, before or after connecting. Returns its
 * handle (>= 0) or -SKR_FULL / -SKR_BAD_NAME. */
int skr_channel(skr_flow* f, const char* short_name, const char* mime);
/* Declares a service channel: `fn` answers its requests. Returns >= 0 or -SKR_FULL/-SKR_BAD_NAME.
 */
int skr_service_add(skr_flow* f, const char* short_name, skr_service_fn fn, void* user);
/* Subscribes to a channel by its full name (no spaces); follows it whenever it exists. */
skr_status skr_subscribe(skr_flow* f, const char* full_name, skr_data_fn fn, void* user);
/* Follows a sync source by its full name; `fn` runs at each pulse, then SYNC_DONE is sent. */
skr_status skr_follow(skr_flow* f, const char* full_name, skr_pulse_fn fn, void* user);

/* Reads what the line holds and runs the session: call it from the loop, often. */
void skr_poll(skr_flow* f);
/* A transport of whole frames (io.read NULL): one frame from the hub, its 4 length bytes included
 * (a frame longer than SKR_RX_MAX is dropped and counted in stats.line.too_long). */
void skr_input_frame(skr_flow* f, const uint8_t* frame, size_t n);
/* The transport has a new line to the hub (a new UDP session): the session ends and logs in again
 * at the next skr_poll(), without a back-off. */
void skr_restart(skr_flow* f);
/* A transport of whole frames may receive a frame into this buffer (SKR_RX_BUF bytes) before
 * skr_input_frame(): the line's buffer, unused without a line. */
uint8_t* skr_frame_buffer(skr_flow* f);
/* 1 once the session is a flow (GO_ASYNC answered). */
int skr_connected(const skr_flow* f);
/* 1 when the channel has its id (publishing goes out). */
int skr_channel_ready(const skr_flow* f, int handle);
const skr_stats* skr_get_stats(skr_flow* f); /* line counters brought up to date */

skr_status skr_publish(skr_flow* f, int handle, const void* data, size_t n);
/* VAR_SET_ASYNC in the flow's current database: describe channels as any satellite does. */
skr_status skr_var_set_int64(skr_flow* f, const char* key, int64_t v);
skr_status skr_var_set_string(skr_flow* f, const char* key, const char* s);
/* DB_READ (1.6) of `key` in database `db` (a board's own variables: the database named after the
 * account it logged in as). The answer comes to `fn` inside a later skr_poll(). One read at a
 * time (SKR_BUSY while one is pending); a read pending when the session is lost gets no answer. */
skr_status skr_var_get(skr_flow* f, const char* db, const char* key, skr_value_fn fn, void* user);

/* --- values (binary Variants) --------------------------------------------------------------- */
void skr_put_null(skr_out* o);
void skr_put_bool(skr_out* o, int v);
void skr_put_int64(skr_out* o, int64_t v);
void skr_put_string(skr_out* o, const char* s, size_t n);
/* Each returns 1 and sets *v when the value is of that type (int64 also takes uint64 and bool
 * values), else 0. A string is not NUL-terminated. */
int skr_value_int64(const uint8_t* value, size_t len, int64_t* v);
int skr_value_string(const uint8_t* value, size_t len, const char** s, size_t* n);

/* Floats (only linked when called): float64 on the wire, the board's double (32 bits on AVR). */
void skr_put_float64(skr_out* o, double v);
int skr_value_float64(const uint8_t* value, size_t len, double* v);
skr_status skr_var_set_float64(skr_flow* f, const char* key, double v);

/* Internal, for skr_float.c: a VAR_SET_ASYNC frame up to its value, and sending a frame. */
skr_status skr_var_begin_(skr_flow* f, skr_out* o, const char* key);
skr_status skr_send_(skr_flow* f, skr_out* o);

#ifdef __cplusplus
}
#endif

#endif /* SKR_FLOW_H */
