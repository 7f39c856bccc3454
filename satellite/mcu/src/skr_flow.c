/* SPDX-License-Identifier: Apache-2.0 */
#include "skr_flow.h"

#include "skr_codes.h"

#include <string.h>

#if SKR_PROTOCOL_MINOR < 12
#error "skr_codes.h predates SESSION_LIMITS (1.12): regenerate it with tools/flow-catalogue --write"
#endif

#if SKR_RX_MAX < 64
#error "SKR_RX_MAX below 64: a hub refuses such a limit"
#endif
#if SKR_MAX_CHANNELS > 255 || SKR_MAX_SERVICES > 255 || SKR_MAX_SUBS > 255
#error "the SKR_MAX_* tables hold 255 entries at most"
#endif

enum { ST_BACKOFF, ST_WAIT_LOGIN, ST_WAIT_LIMITS, ST_WAIT_ASYNC, ST_CONNECTED };

/* Tags of asynchronous commands: which table entry an EV_CHAN_ADDED or EV_ERROR is about. */
#define TAG_CHAN 0x100u
#define TAG_SERVICE 0x200u
#define TAG_SUB 0x300u
#define TAG_PROBE 0x400u
#define TAG_READ 0x500u
/* skr_flow.adding when no CHAN_ADD waits for its answer. */
#define NOT_ADDING 0xFFu

const char* skr_strerror(skr_status s) {
  switch (s) {
    case SKR_OK:
      return "ok";
    case SKR_OFFLINE:
      return "offline";
    case SKR_TOO_BIG:
      return "too big";
    case SKR_FULL:
      return "table full";
    case SKR_BAD_HANDLE:
      return "bad handle";
    case SKR_BAD_NAME:
      return "bad name";
    case SKR_BUSY:
      return "busy";
  }
  return "?";
}

/* --- writing ------------------------------------------------------------------------------- */

static void put_raw(skr_out* o, const void* p, size_t n) {
  if (!o->ok || o->cap - o->len < n) {
    o->ok = 0;
    return;
  }
  memcpy(o->p + o->len, p, n);
  o->len += n;
}
static void put_u8(skr_out* o, uint8_t v) {
  put_raw(o, &v, 1);
}
static void put_le(skr_out* o, uint32_t v, uint8_t n) {
  uint8_t b[4];
  for (uint8_t i = 0; i < n; ++i, v >>= 8) b[i] = (uint8_t)v;
  put_raw(o, b, n);
}
static void put_str16(skr_out* o, const char* s, size_t n) {
  put_le(o, (uint32_t)n, 2);
  put_raw(o, s, n);
}
static void put_name(skr_out* o, const char* s) {
  put_str16(o, s, strlen(s));
}

void skr_put_null(skr_out* o) {
  put_u8(o, 0x00);
}
void skr_put_bool(skr_out* o, int v) {
  put_u8(o, 0x01);
  put_u8(o, v ? 1 : 0);
}
void skr_put_int64(skr_out* o, int64_t v) {
  uint8_t b[9];
  uint64_t u = (uint64_t)v;
  b[0] = 0x02;
  for (uint8_t i = 1; i < 9; ++i, u >>= 8) b[i] = (uint8_t)u;
  put_raw(o, b, sizeof b);
}
void skr_put_string(skr_out* o, const char* s, size_t n) {
  put_u8(o, 0x05);
  put_le(o, (uint32_t)n, 4);
  put_raw(o, s, n);
}

/* A frame: its length is filled in by skr_send_, which encodes it in place and writes it. */
static void begin(skr_flow* f, skr_out* o, uint8_t code) {
  o->p = f->tx_buf + SKR_TX_LEAD;
  o->cap = SKR_TX_MAX;
  o->len = 4;
  o->ok = 1;
  put_u8(o, code);
}

skr_status skr_send_(skr_flow* f, skr_out* o) {
  if (!o->ok) {
    ++f->stats.sent_dropped;
    return SKR_TOO_BIG;
  }
  uint32_t n = (uint32_t)(o->len - 4);
  for (uint8_t i = 0; i < 4; ++i, n >>= 8) o->p[i] = (uint8_t)n;
  if (!f->io.read) { /* whole frames: the transport frames them */
    f->io.write(f->io.ctx, o->p, o->len);
    return SKR_OK;
  }
  const size_t w = skr_line_encode(o->p, o->len, f->tx_buf, sizeof f->tx_buf);
  f->io.write(f->io.ctx, f->tx_buf, w);
  return SKR_OK;
}

/* --- reading: every length is checked against the bytes left before use ------------------- */

typedef struct {
  const uint8_t* p;
  size_t left;
  uint8_t bad;
} rd;

static const uint8_t* take(rd* r, size_t n) {
  if (r->bad || r->left < n) {
    r->bad = 1;
    return 0;
  }
  const uint8_t* p = r->p;
  r->p += n;
  r->left -= n;
  return p;
}
static uint32_t get_le(rd* r, uint8_t n) {
  const uint8_t* p = take(r, n);
  uint32_t v = 0;
  if (p) {
    while (n-- > 0) v = (v << 8) | p[n];
  }
  return v;
}
static const uint8_t* get_str16(rd* r, size_t* n) {
  *n = get_le(r, 2);
  return take(r, *n);
}

/* --- the session --------------------------------------------------------------------------- */

static uint32_t now(skr_flow* f) {
  return f->io.millis(f->io.ctx);
}
static int reached(uint32_t t, uint32_t due) {
  return (int32_t)(t - due) >= 0;
}

static void lost(skr_flow* f) {
  f->read_fn = 0; /* its answer will not come */
  f->state = ST_BACKOFF;
  f->due_ms = now(f) + f->backoff_ms;
  f->backoff_ms = f->backoff_ms >= SKR_BACKOFF_MAX_MS / 2 ? SKR_BACKOFF_MAX_MS : f->backoff_ms * 2;
}

static void wait_reply(skr_flow* f, uint8_t state) {
  f->state = state;
  f->due_ms = now(f) + SKR_REPLY_TIMEOUT_MS;
}

static void login(skr_flow* f) {
  uint8_t i;
  for (i = 0; i < f->n_chans; ++i) f->chans[i].id = 0;
#if SKR_MAX_SERVICES > 0
  for (i = 0; i < f->n_services; ++i) f->services[i].id = 0;
#endif
  for (i = 0; i < f->n_subs; ++i) f->subs[i].id = 0;
  f->adding = NOT_ADDING;
  skr_out o;
  begin(f, &o, SKR_CODE_LOGIN);
  put_le(&o, SKR_PROTOCOL_MAJOR, 2);
  put_le(&o, SKR_PROTOCOL_MINOR, 2);
  put_u8(&o, 0); /* values in binary */
  put_name(&o, f->user);
  put_name(&o, f->password);
  put_name(&o, f->client);
  ++f->stats.logins;
  if (skr_send_(f, &o) != SKR_OK) {
    lost(f);
    return;
  }
  wait_reply(f, ST_WAIT_LOGIN);
}

static void send_limits(skr_flow* f) {
  skr_out o;
  begin(f, &o, SKR_CODE_SESSION_LIMITS);
  put_le(&o, SKR_RX_MAX, 4);
  put_le(&o, 0, 4); /* events: none beyond the board's own channels and its watch */
  size_t n = 0;
  uint8_t i;
  for (i = 0; i < f->n_subs; ++i) n += strlen(f->subs[i].name) + (i > 0);
  put_le(&o, (uint32_t)n, 2);
  for (i = 0; i < f->n_subs; ++i) {
    if (i > 0) put_u8(&o, ' ');
    put_raw(&o, f->subs[i].name, strlen(f->subs[i].name));
  }
  if (skr_send_(f, &o) != SKR_OK) {
    lost(f);
    return;
  }
  wait_reply(f, ST_WAIT_LIMITS);
}

static void chan_add(skr_flow* f, uint32_t tag, uint8_t kind, const char* name, const char* mime) {
  skr_out o;
  begin(f, &o, SKR_CODE_CHAN_ADD);
  put_le(&o, tag, 4);
  put_u8(&o, kind);
  put_name(&o, name);
  put_name(&o, mime);
  put_u8(&o, 0);    /* props: binary */
  skr_put_null(&o); /* none */
  (void)skr_send_(f, &o);
}

/* The channels are added one at a time: the next CHAN_ADD goes when the hub has answered the last
 * one (EV_CHAN_ADDED, or EV_ERROR with its tag). An Uno keeps 127 received bytes while it writes
 * (the serial ring and SKR_STASH): every CHAN_ADD sent at once would bring back more answers
 * than that (each EV_CHAN_ADDED is longer than its CHAN_ADD), and at 1,000,000 baud they arrive
 * before the board has read the first. An answer that does not come within SKR_REPLY_TIMEOUT_MS
 * (lost on a noisy line) starts the session again: a channel without its id is never used. */

/* The table entry `k` counts channels first, then services. */
static void add_from(skr_flow* f, uint8_t k) {
  for (; k < f->n_chans; ++k) {
    if (f->chans[k].id != 0) continue;
    f->adding = k;
    f->due_ms = now(f) + SKR_REPLY_TIMEOUT_MS;
    chan_add(f, TAG_CHAN + k, SKR_KIND_STREAMING, f->chans[k].name, f->chans[k].mime);
    return;
  }
#if SKR_MAX_SERVICES > 0
  for (; k < f->n_chans + f->n_services; ++k) {
    const uint8_t i = (uint8_t)(k - f->n_chans);
    if (f->services[i].id != 0) continue;
    f->adding = k;
    f->due_ms = now(f) + SKR_REPLY_TIMEOUT_MS;
    chan_add(f, TAG_SERVICE + i, SKR_KIND_SERVICE, f->services[i].name, "");
    return;
  }
#endif
  f->adding = NOT_ADDING;
}

/* Whether `tag` is the CHAN_ADD waiting for its answer. */
static int adding_tag(const skr_flow* f, uint32_t tag) {
  if (f->adding == NOT_ADDING) return 0;
  return f->adding < f->n_chans ? tag == TAG_CHAN + f->adding
                                : tag == TAG_SERVICE + (uint32_t)(f->adding - f->n_chans);
}

static void on_reply_ok(skr_flow* f, rd* r) {
  switch (f->state) {
    case ST_WAIT_LOGIN:
      (void)get_le(r, 4); /* the hub's major and minor: any minor of major 1 speaks 1.12's start */
      if (r->bad) return;
      send_limits(f);
      return;
    case ST_WAIT_LIMITS: {
      skr_out o;
      begin(f, &o, SKR_CODE_GO_ASYNC);
      if (skr_send_(f, &o) != SKR_OK) {
        lost(f);
        return;
      }
      wait_reply(f, ST_WAIT_ASYNC);
      return;
    }
    case ST_WAIT_ASYNC:
      f->state = ST_CONNECTED;
      f->backoff_ms = SKR_BACKOFF_MS;
      f->probe_ms = now(f);
      add_from(f, 0);
      return;
    default:
      return; /* a reply nobody waits for: nothing to do */
  }
}

static int same(const char* name, const uint8_t* s, size_t n) {
  return strlen(name) == n && memcmp(name, s, n) == 0;
}

static void on_chan_added(skr_flow* f, rd* r) {
  const uint32_t tag = get_le(r, 4);
  const uint16_t id = (uint16_t)get_le(r, 2);
  (void)take(r, 8); /* hash */
  const uint8_t kind = (uint8_t)get_le(r, 1);
  size_t n, skip;
  const uint8_t* name = get_str16(r, &n);
  (void)get_str16(r, &skip); /* owner */
  (void)take(r, 4);          /* owner_connection */
  (void)get_str16(r, &skip); /* mime */
  (void)take(r, 4);          /* subscribers */
  (void)take(r, 2);          /* props: at least an encoding and a Variant tag */
  if (r->bad) return;
  const uint32_t k = tag & 0xFFu;
  if ((tag & ~0xFFu) == TAG_CHAN && k < f->n_chans) f->chans[k].id = id;
#if SKR_MAX_SERVICES > 0
  if ((tag & ~0xFFu) == TAG_SERVICE && k < f->n_services) f->services[k].id = id;
#endif
  if (adding_tag(f, tag)) add_from(f, (uint8_t)(f->adding + 1));
  for (uint8_t i = 0; i < f->n_subs; ++i) {
    skr_sub* s = &f->subs[i];
    if (s->kind != kind || !same(s->name, name, n)) continue;
    s->id = id;
    skr_out o;
    begin(f, &o, s->kind == SKR_KIND_SYNC ? SKR_CODE_SYNC_FOLLOW : SKR_CODE_SUBSCRIBE);
    put_le(&o, TAG_SUB + i, 4);
    put_le(&o, id, 2);
    if (s->kind == SKR_KIND_SYNC) put_le(&o, 1, 4); /* every pulse */
    (void)skr_send_(f, &o);
  }
}

static void on_chan_removed(skr_flow* f, rd* r) {
  const uint16_t id = (uint16_t)get_le(r, 2);
  size_t n;
  (void)take(r, 8);
  (void)get_str16(r, &n);
  if (r->bad) return;
  uint8_t i;
  for (i = 0; i < f->n_subs; ++i)
    if (f->subs[i].id == id) f->subs[i].id = 0;
  for (i = 0; i < f->n_chans; ++i)
    if (f->chans[i].id == id) f->chans[i].id = 0;
#if SKR_MAX_SERVICES > 0
  for (i = 0; i < f->n_services; ++i)
    if (f->services[i].id == id) f->services[i].id = 0;
#endif
}

static skr_sub* sub_of(skr_flow* f, uint16_t id, uint8_t kind) {
  for (uint8_t i = 0; i < f->n_subs; ++i)
    if (id != 0 && f->subs[i].id == id && f->subs[i].kind == kind) return &f->subs[i];
  return 0;
}

#if SKR_MAX_SERVICES > 0
static void on_service_request(skr_flow* f, rd* r) {
  const uint16_t id = (uint16_t)get_le(r, 2);
  const uint8_t* request = take(r, 8);
  size_t cmd_n, who_n;
  const uint8_t* cmd = get_str16(r, &cmd_n);
  (void)get_str16(r, &who_n);
  const uint8_t enc = (uint8_t)get_le(r, 1);
  if (r->bad || enc != 0 || r->left == 0) {
    r->bad = 1;
    return;
  }
  skr_service* s = 0;
  for (uint8_t i = 0; i < f->n_services; ++i)
    if (id != 0 && f->services[i].id == id) s = &f->services[i];
  if (!s) return;
  skr_out o;
  begin(f, &o, SKR_CODE_SERVICE_RESPONSE);
  put_le(&o, id, 2);
  put_raw(&o, request, 8);
  put_u8(&o, 0);
  const size_t at = o.len;
  f->in_handler = 1;
  s->fn(s->user, (const char*)cmd, cmd_n, r->p, r->left, &o);
  f->in_handler = 0;
  if (!o.ok || o.len == at) {
    if (!o.ok) ++f->stats.sent_dropped;
    o.len = at;
    o.ok = 1;
    skr_put_null(&o);
  }
  (void)skr_send_(f, &o);
}
#endif

static void on_pulse(skr_flow* f, rd* r) {
  const uint16_t id = (uint16_t)get_le(r, 2);
  const uint8_t* seq = take(r, 8);
  (void)take(r, 8); /* source_time_ns */
  const uint32_t dropped = get_le(r, 4);
  if (r->bad) return;
  skr_sub* s = sub_of(f, id, SKR_KIND_SYNC);
  if (!s) return;
  s->fn.pulse(
      s->user,
      (uint32_t)seq[0] | (uint32_t)seq[1] << 8 | (uint32_t)seq[2] << 16 | (uint32_t)seq[3] << 24,
      dropped);
  skr_out o;
  begin(f, &o, SKR_CODE_SYNC_DONE);
  put_le(&o, id, 2);
  put_raw(&o, seq, 8);
  (void)skr_send_(f, &o);
}

static void on_error(skr_flow* f, uint16_t error) {
  ++f->stats.errors;
  f->stats.last_error = error;
}

/* The answer to the pending skr_var_get with `tag`: its value, or 0 when it failed. */
static void on_read(skr_flow* f, uint32_t tag, const uint8_t* value, size_t len) {
  skr_value_fn fn = f->read_fn;
  if (!fn || tag != (TAG_READ | f->read_tag)) return;
  f->read_fn = 0; /* before the call: the callback may read again */
  fn(f->read_user, value, len);
}

/* One frame off the line. A frame that does not match its layout is dropped and counted. */
static void on_frame(skr_flow* f, const uint8_t* p, size_t n) {
  rd r;
  r.p = p;
  r.left = n;
  r.bad = 0;
  const uint32_t len = get_le(&r, 4);
  const uint8_t code = (uint8_t)get_le(&r, 1);
  if (r.bad || len != n - 4) {
    ++f->stats.frames_bad;
    return;
  }
  f->heard_ms = now(f);
  const int async = f->state >= ST_WAIT_ASYNC;
  size_t skip;
  switch (code) {
    case SKR_CODE_REPLY_OK:
      on_reply_ok(f, &r);
      break;
    case SKR_CODE_REPLY_ERROR: {
      const uint16_t e = (uint16_t)get_le(&r, 2);
      (void)get_str16(&r, &skip);
      if (r.bad) break;
      on_error(f, e);
      /* A refused login step, or a hub that has no session for this board any more. */
      if (f->state != ST_BACKOFF) lost(f);
      break;
    }
    case SKR_CODE_EV_ERROR: {
      const uint8_t command = (uint8_t)get_le(&r, 1);
      const uint32_t tag = get_le(&r, 4);
      (void)take(&r, 2);
      const uint16_t e = (uint16_t)get_le(&r, 2);
      (void)get_str16(&r, &skip);
      if (r.bad) break;
      on_error(f, e);
      if (command == SKR_CODE_DB_READ) on_read(f, tag, 0, 0);
      if (e == SKR_ERROR_NOT_LOGGED_IN && f->state != ST_BACKOFF) {
        lost(f);
      } else if (f->state == ST_CONNECTED && adding_tag(f, tag)) {
        add_from(f, (uint8_t)(f->adding + 1)); /* refused (last_error says why): the next one */
      }
      break;
    }
    case SKR_CODE_EV_CHAN_ADDED:
      if (async) on_chan_added(f, &r);
      break;
    case SKR_CODE_EV_CHAN_REMOVED:
      if (async) on_chan_removed(f, &r);
      break;
    case SKR_CODE_EV_DATA: {
      const uint16_t id = (uint16_t)get_le(&r, 2);
      skr_sub* s = r.bad || !async ? 0 : sub_of(f, id, SKR_KIND_STREAMING);
      if (s) s->fn.data(s->user, r.p, r.left);
      break;
    }
#if SKR_MAX_SERVICES > 0
    case SKR_CODE_EV_SERVICE_REQUEST:
      if (async) on_service_request(f, &r);
      break;
#endif
    case SKR_CODE_EV_SYNC_PULSE:
      if (async) on_pulse(f, &r);
      break;
    case SKR_CODE_EV_DB_VALUE: {
      const uint32_t tag = get_le(&r, 4);
      const uint8_t enc = (uint8_t)get_le(&r, 1); /* the board asks for binary values */
      if (r.bad || enc != 0 || r.left == 0) {
        r.bad = 1;
        break;
      }
      if (async) on_read(f, tag, r.p, r.left);
      break;
    }
    default:
      break; /* events this board has no use for (EV_TIME_PROBE: the hub is alive) */
  }
  if (r.bad) ++f->stats.frames_bad;
}

void skr_init(skr_flow* f, const skr_io* io, const char* user, const char* password,
              const char* client_name) {
  memset(f, 0, sizeof *f);
  f->io = *io;
  f->user = user;
  f->password = password;
  f->client = client_name;
  f->state = ST_BACKOFF;
  f->backoff_ms = SKR_BACKOFF_MS;
  f->due_ms = now(f);
  f->adding = NOT_ADDING;
  skr_line_rx_init(&f->rx, f->rx_buf, sizeof f->rx_buf);
}

void skr_poll(skr_flow* f) {
  if (f->in_handler) return;
  int c;
  while (f->io.read && (c = f->io.read(f->io.ctx)) >= 0) {
    const size_t n = skr_line_rx_byte(&f->rx, (uint8_t)c);
    if (n > 0) on_frame(f, skr_line_rx_frame(&f->rx), n);
  }
  const uint32_t t = now(f);
  switch (f->state) {
    case ST_BACKOFF:
      if (reached(t, f->due_ms)) login(f);
      break;
    case ST_CONNECTED:
      if (reached(t, f->heard_ms + SKR_SILENCE_MS) ||
          (f->adding != NOT_ADDING && reached(t, f->due_ms))) {
        lost(f);
      } else if (reached(t, f->probe_ms + SKR_PROBE_MS)) {
        /* Liveness on a flow (PING is synchronous): the hub answers EV_TIME_PROBE. */
        skr_out o;
        begin(f, &o, SKR_CODE_TIME_PROBE);
        put_le(&o, TAG_PROBE, 4);
        put_le(&o, t, 4);
        put_le(&o, 0, 4);
        (void)skr_send_(f, &o);
        f->probe_ms = t;
      }
      break;
    default:
      if (reached(t, f->due_ms)) lost(f);
      break;
  }
}

void skr_input_frame(skr_flow* f, const uint8_t* frame, size_t n) {
  if (f->in_handler) return;
  if (n > SKR_RX_MAX) {
    ++f->rx.stats.too_long;
    return;
  }
  ++f->rx.stats.frames;
  on_frame(f, frame, n);
}

void skr_restart(skr_flow* f) {
  f->state = ST_BACKOFF;
  f->due_ms = now(f);
}

uint8_t* skr_frame_buffer(skr_flow* f) {
  return f->rx_buf;
}

static int bad_name(const char* s) {
  if (!s || !*s) return 1;
  for (; *s; ++s)
    if (*s == ' ') return 1;
  return 0;
}

int skr_channel(skr_flow* f, const char* short_name, const char* mime) {
  if (bad_name(short_name)) return -SKR_BAD_NAME;
  if (f->n_chans >= SKR_MAX_CHANNELS) return -SKR_FULL;
  const uint8_t k = f->n_chans++;
  f->chans[k].name = short_name;
  f->chans[k].mime = mime ? mime : "";
  f->chans[k].id = 0;
  if (f->state == ST_CONNECTED && f->adding == NOT_ADDING) add_from(f, 0);
  return k;
}

int skr_service_add(skr_flow* f, const char* short_name, skr_service_fn fn, void* user) {
#if SKR_MAX_SERVICES > 0
  if (bad_name(short_name) || !fn) return -SKR_BAD_NAME;
  if (f->n_services >= SKR_MAX_SERVICES) return -SKR_FULL;
  const uint8_t k = f->n_services++;
  f->services[k].name = short_name;
  f->services[k].fn = fn;
  f->services[k].user = user;
  f->services[k].id = 0;
  if (f->state == ST_CONNECTED && f->adding == NOT_ADDING) add_from(f, 0);
  return k;
#else
  (void)f, (void)short_name, (void)fn, (void)user;
  return -SKR_FULL;
#endif
}

/* A watch is sent at login: one declared while connected takes effect at the next login. */
static skr_status watch(skr_flow* f, const char* name, uint8_t kind, void* user, skr_sub** out) {
  if (bad_name(name)) return SKR_BAD_NAME;
  if (f->n_subs >= SKR_MAX_SUBS) return SKR_FULL;
  skr_sub* s = &f->subs[f->n_subs++];
  s->name = name;
  s->user = user;
  s->kind = kind;
  s->id = 0;
  *out = s;
  return SKR_OK;
}

skr_status skr_subscribe(skr_flow* f, const char* full_name, skr_data_fn fn, void* user) {
  skr_sub* s;
  const skr_status st = watch(f, full_name, SKR_KIND_STREAMING, user, &s);
  if (st == SKR_OK) s->fn.data = fn;
  return st;
}

skr_status skr_follow(skr_flow* f, const char* full_name, skr_pulse_fn fn, void* user) {
  skr_sub* s;
  const skr_status st = watch(f, full_name, SKR_KIND_SYNC, user, &s);
  if (st == SKR_OK) s->fn.pulse = fn;
  return st;
}

int skr_connected(const skr_flow* f) {
  return f->state == ST_CONNECTED;
}

int skr_channel_ready(const skr_flow* f, int handle) {
  return handle >= 0 && handle < f->n_chans && f->state == ST_CONNECTED && f->chans[handle].id != 0;
}

const skr_stats* skr_get_stats(skr_flow* f) {
  f->stats.line = f->rx.stats;
  return &f->stats;
}

skr_status skr_publish(skr_flow* f, int handle, const void* data, size_t n) {
  if (handle < 0 || handle >= f->n_chans) return SKR_BAD_HANDLE;
  if (f->in_handler) return SKR_BUSY;
  if (!skr_channel_ready(f, handle)) {
    ++f->stats.sent_dropped;
    return SKR_OFFLINE;
  }
  skr_out o;
  begin(f, &o, SKR_CODE_PUBLISH);
  put_le(&o, f->chans[handle].id, 2);
  put_raw(&o, data, n);
  return skr_send_(f, &o);
}

skr_status skr_var_begin_(skr_flow* f, skr_out* o, const char* key) {
  if (f->in_handler) return SKR_BUSY;
  if (f->state != ST_CONNECTED) {
    ++f->stats.sent_dropped;
    return SKR_OFFLINE;
  }
  begin(f, o, SKR_CODE_VAR_SET_ASYNC);
  put_le(o, 0, 4);
  put_name(o, key);
  put_u8(o, 0);
  return SKR_OK;
}

skr_status skr_var_set_int64(skr_flow* f, const char* key, int64_t v) {
  skr_out o;
  const skr_status st = skr_var_begin_(f, &o, key);
  if (st != SKR_OK) return st;
  skr_put_int64(&o, v);
  return skr_send_(f, &o);
}

skr_status skr_var_set_string(skr_flow* f, const char* key, const char* s) {
  skr_out o;
  const skr_status st = skr_var_begin_(f, &o, key);
  if (st != SKR_OK) return st;
  skr_put_string(&o, s, strlen(s));
  return skr_send_(f, &o);
}

skr_status skr_var_get(skr_flow* f, const char* db, const char* key, skr_value_fn fn, void* user) {
  if (f->in_handler || f->read_fn) return SKR_BUSY;
  if (f->state != ST_CONNECTED) return SKR_OFFLINE;
  skr_out o;
  begin(f, &o, SKR_CODE_DB_READ);
  put_le(&o, TAG_READ | (uint8_t)(f->read_tag + 1), 4);
  put_name(&o, db);
  put_u8(&o, 0); /* get */
  put_name(&o, key);
  const skr_status st = skr_send_(f, &o);
  if (st != SKR_OK) return st;
  ++f->read_tag;
  f->read_fn = fn;
  f->read_user = user;
  return SKR_OK;
}

/* --- reading values ------------------------------------------------------------------------ */

int skr_value_int64(const uint8_t* value, size_t len, int64_t* v) {
  if (len == 2 && value[0] == 0x01 && value[1] <= 1) {
    *v = value[1];
    return 1;
  }
  if (len != 9 || (value[0] != 0x02 && value[0] != 0x03)) return 0;
  uint64_t u = 0;
  for (uint8_t i = 8; i > 0; --i) u = (u << 8) | value[i];
  *v = (int64_t)u;
  return 1;
}

int skr_value_string(const uint8_t* value, size_t len, const char** s, size_t* n) {
  if (len < 5 || value[0] != 0x05) return 0;
  rd r;
  r.p = value + 1;
  r.left = len - 1;
  r.bad = 0;
  const uint32_t m = get_le(&r, 4);
  if (m != r.left) return 0;
  *s = (const char*)r.p;
  *n = m;
  return 1;
}
