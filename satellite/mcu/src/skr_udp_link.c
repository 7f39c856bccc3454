/* SPDX-License-Identifier: Apache-2.0 */
#include "skr_udp_link.h"

#include "skr_codes.h"

#include <string.h>

enum { STEP_START, STEP_HELLO, STEP_OPEN, STEP_UP };

static uint32_t now(skr_udp_link* l) {
  return l->port.millis(l->port.ctx);
}

static void send_whole(skr_udp_link* l, const uint8_t* d, size_t n) {
  if (n > 0) l->port.send(l->port.ctx, d, n, 0, 0, 0, 0);
}

/* Sends the handshake's current datagram (HELLO or OPEN) and waits longer the next time. */
static void send_step(skr_udp_link* l) {
  uint8_t d[SKR_UDP_HANDSHAKE_MAX];
  if (l->step == STEP_HELLO) {
    uint8_t nonce[8];
    memcpy(nonce, l->s.client_nonce, 8);
    send_whole(l, d, skr_udp_make_hello(&l->s, l->user, nonce, d, sizeof d));
  } else {
    ++l->tries;
    send_whole(l, d, skr_udp_make_open(&l->s, l->user, l->cookie, d, sizeof d));
  }
  l->due_ms = now(l) + l->wait_ms;
  l->wait_ms = l->wait_ms >= SKR_BACKOFF_MAX_MS / 2 ? SKR_BACKOFF_MAX_MS : l->wait_ms * 2;
}

static void hello(skr_udp_link* l) {
  uint8_t nonce[8];
  l->port.random(l->port.ctx, nonce, sizeof nonce);
  memcpy(l->s.client_nonce, nonce, 8);
  l->s.session = 0;
  l->step = STEP_HELLO;
  l->tries = 0;
  ++l->stats.handshakes;
  send_step(l);
}

/* The session is gone (closed by either end): the flow is not connected until a new one opens. */
static void session_lost(skr_udp_link* l) {
  l->s.session = 0;
  l->step = STEP_START;
  l->wait_ms = SKR_UDP_RETRY_MS;
  skr_restart(l->f);
}

void skr_udp_link_close(skr_udp_link* l) {
  if (l->s.session != 0) {
    uint8_t d[SKR_UDP_DATA_OVERHEAD];
    send_whole(l, d, skr_udp_make_close(&l->s, d, sizeof d));
  }
  session_lost(l);
}

/* The flow's io.write: one whole frame. */
static void write_frame(void* ctx, const uint8_t* frame, size_t n) {
  skr_udp_link* l = (skr_udp_link*)ctx;
  uint8_t head[SKR_UDP_HEAD_BYTES], mac[8];
  if (n > 4 && frame[4] == SKR_CODE_LOGIN) {
    /* Logging in again on a session that carried a login: the flow lost the hub (silence, a
     * refusal). A new UDP session first; the flow logs in once it is open (skr_restart). */
    if (l->used) {
      skr_udp_link_close(l);
      --l->f->stats.logins; /* this one never goes out: counted when the next one does */
    }
    l->used = 1;
  }
  if (l->step != STEP_UP || !skr_udp_seal(&l->s, SKR_UDP_DATA, frame, n, head, mac)) {
    ++l->stats.frames_unsent;
    return;
  }
  l->port.send(l->port.ctx, head, sizeof head, frame, n, mac, sizeof mac);
}

static uint32_t flow_millis(void* ctx) {
  return now((skr_udp_link*)ctx);
}

void skr_udp_link_init(skr_udp_link* l, skr_flow* f, const skr_udp_port* port, const char* user,
                       const uint8_t key[16], const char* client_name) {
  skr_io io;
  memset(l, 0, sizeof *l);
  skr_udp_init(&l->s, key);
  l->port = *port;
  l->f = f;
  l->user = user;
  l->step = STEP_START;
  l->wait_ms = SKR_UDP_RETRY_MS;
  io.ctx = l;
  io.read = 0; /* whole frames */
  io.write = write_frame;
  io.millis = flow_millis;
  skr_init(f, &io, user, "", client_name);
}

void skr_udp_link_input_parts(skr_udp_link* l, const uint8_t* head, const uint8_t* frame, size_t n,
                              const uint8_t* mac) {
  if (l->step != STEP_UP) return;
  switch (skr_udp_take_parts(&l->s, head, frame, n, mac)) {
    case SKR_UDP_RX_DATA:
      skr_input_frame(l->f, frame, n);
      break;
    case SKR_UDP_RX_CLOSE:
      ++l->stats.closed_by_hub;
      session_lost(l);
      break;
    default:
      break; /* counted in l->s.stats */
  }
}

void skr_udp_link_input(skr_udp_link* l, const uint8_t* d, size_t n) {
  if (l->step == STEP_HELLO && skr_udp_take_cookie(&l->s, d, n, l->cookie)) {
    l->step = STEP_OPEN;
    l->wait_ms = SKR_UDP_RETRY_MS;
    send_step(l);
  } else if (l->step == STEP_OPEN && skr_udp_take_accept(&l->s, d, n)) {
    l->step = STEP_UP;
    l->used = 0;
    l->wait_ms = SKR_UDP_RETRY_MS;
    ++l->stats.sessions;
    skr_restart(l->f); /* log in now */
  } else if (n >= SKR_UDP_DATA_OVERHEAD) {
    skr_udp_link_input_parts(l, d, d + SKR_UDP_HEAD_BYTES, n - SKR_UDP_DATA_OVERHEAD, d + n - 8);
  } else {
    ++l->s.stats.other;
  }
}

void skr_udp_link_poll(skr_udp_link* l) {
  switch (l->step) {
    case STEP_UP:
      skr_poll(l->f);
      return;
    case STEP_START:
      hello(l);
      return;
    default:
      if ((int32_t)(now(l) - l->due_ms) < 0) return;
      if (l->step == STEP_OPEN && l->tries >= SKR_UDP_OPEN_TRIES)
        hello(l);
      else
        send_step(l);
      return;
  }
}

int skr_udp_link_open(const skr_udp_link* l) {
  return l->step == STEP_UP;
}
