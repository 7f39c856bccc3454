/* SPDX-License-Identifier: Apache-2.0 */
/* A serial line between the hub and a board (tests/boards, bench/serial_udp): a pseudo-terminal
 * of its own, which the hub opens as if it were the board's port, joined to the board's terminal
 * (a simavr_runner's pty), bytes copied both ways.
 *
 *   line_relay <board tty> [--baud N] [--seed N] [--error-rate R]
 *              [--unplug-at-ms N --replug-after-ms M] [--link PATH]
 *
 * --baud paces each direction at the line's rate (N / 10 bytes per second), as a real line
 * would. --error-rate R: each byte, with probability R, is dropped, has one bit flipped or has a
 * random byte inserted before it (one of the three, equally likely), from a generator seeded by
 * --seed (default 1) for each direction, so that a run can be repeated. --unplug-at-ms: the
 * relay's terminal goes away at that time after the start (the hub's end reads a hang-up; what
 * the board sends meanwhile is lost) and a new one comes --replug-after-ms later. --link keeps a
 * symbolic link to the current terminal (absent while unplugged), for a device name in a glob.
 *
 * stdout: `PTY /dev/pts/M` first, again after each replug; at exit (SIGTERM, SIGINT, or the
 * board's terminal hung up) one line of counters:
 * `RELAY to_board bytes B dropped D flipped F inserted I to_hub bytes ... lost_unplugged L`. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#define QUEUE_CAP 65536u

typedef struct {
  const char* name;
  uint8_t buf[QUEUE_CAP];
  size_t head, len;
  uint64_t next_ns; /* pacing: when the next byte may go */
  uint64_t rng;
  uint64_t bytes, dropped, flipped, inserted;
} direction;

static volatile sig_atomic_t stop_requested;

static void on_stop(int sig) {
  (void)sig;
  stop_requested = 1;
}

static uint64_t now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* splitmix64: small, and the same sequence on every machine for a seed. */
static uint64_t next_random(uint64_t* state) {
  uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

static double uniform(uint64_t* state) {
  return (double)(next_random(state) >> 11) * (1.0 / 9007199254740992.0);
}

static void push(direction* d, uint8_t byte) {
  d->buf[(d->head + d->len) % QUEUE_CAP] = byte;
  ++d->len;
}

/* How many bytes may be read for the queue: each may come with an inserted one, and the queue
 * takes no more than half its capacity, so that a slow reader holds the writer back (as a line's
 * flow control would) and nothing is lost for it. */
static size_t room(const direction* d) {
  return d->len >= QUEUE_CAP / 2 ? 0 : (QUEUE_CAP / 2 - d->len) / 2;
}

/* Takes bytes read from one end into the queue towards the other, with the line's noise. */
static void take(direction* d, const uint8_t* bytes, size_t n, double error_rate) {
  if (d->len == 0) {
    const uint64_t now = now_ns();
    if (d->next_ns < now) d->next_ns = now; /* an idle line saved no time for later */
  }
  for (size_t i = 0; i < n; ++i) {
    uint8_t b = bytes[i];
    ++d->bytes;
    if (error_rate > 0 && uniform(&d->rng) < error_rate) {
      switch (next_random(&d->rng) % 3) {
        case 0:
          ++d->dropped;
          continue;
        case 1:
          b ^= (uint8_t)(1u << (next_random(&d->rng) % 8));
          ++d->flipped;
          break;
        default:
          push(d, (uint8_t)next_random(&d->rng));
          ++d->inserted;
          break;
      }
    }
    push(d, b);
  }
}

/* Writes what is due to fd (non-blocking); with pacing, one byte per byte time. */
static void give(direction* d, int fd, uint64_t byte_ns) {
  while (d->len > 0) {
    size_t n = d->len;
    if (d->head + n > QUEUE_CAP) n = QUEUE_CAP - d->head;
    if (byte_ns > 0) {
      const uint64_t now = now_ns();
      if (d->next_ns > now) return;
      n = 1;
    }
    const ssize_t w = write(fd, d->buf + d->head, n);
    if (w <= 0) return; /* EAGAIN: the reader is behind; a hang-up shows on read */
    d->head = (d->head + (size_t)w) % QUEUE_CAP;
    d->len -= (size_t)w;
    if (byte_ns > 0) d->next_ns += byte_ns;
  }
}

static int set_raw(int fd) {
  struct termios tio;
  if (tcgetattr(fd, &tio) != 0) return -1;
  cfmakeraw(&tio);
  return tcsetattr(fd, TCSANOW, &tio);
}

/* The hub's end: a new pseudo-terminal, raw. The relay keeps the slave side open too, so that
 * the master never reads a hang-up while the hub has its end closed. */
typedef struct {
  int master, slave;
  char name[128];
} hub_end;

static int plug(hub_end* h, const char* link, FILE* out) {
  if (openpty(&h->master, &h->slave, h->name, NULL, NULL) != 0) return -1;
  if (set_raw(h->slave) != 0 || set_raw(h->master) != 0) return -1;
  fcntl(h->master, F_SETFL, fcntl(h->master, F_GETFL) | O_NONBLOCK);
  if (link) {
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.%d.tmp", link, (int)getpid());
    unlink(tmp);
    if (symlink(h->name, tmp) != 0 || rename(tmp, link) != 0) {
      fprintf(stderr, "RELAY-LINK cannot link %s: %s\n", link, strerror(errno));
    }
  }
  fprintf(out, "PTY %s\n", h->name);
  fflush(out);
  return 0;
}

static void unplug(hub_end* h, const char* link) {
  if (link) unlink(link);
  close(h->master);
  close(h->slave);
  h->master = h->slave = -1;
}

static int usage(void) {
  fprintf(stderr,
          "usage: line_relay <board tty> [--baud N] [--seed N] [--error-rate R]\n"
          "                  [--unplug-at-ms N --replug-after-ms M] [--link PATH]\n");
  return 2;
}

static int parse_u64(const char* text, uint64_t* out) {
  char* end = NULL;
  errno = 0;
  const unsigned long long v = strtoull(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0') return -1;
  *out = v;
  return 0;
}

int main(int argc, char** argv) {
  /* A test or benchmark that dies (an assertion, exit()) takes this process with it. */
  prctl(PR_SET_PDEATHSIG, SIGTERM);
  const char* tty = NULL;
  const char* link = NULL;
  uint64_t baud = 0, seed = 1, unplug_at_ms = 0, replug_after_ms = 0;
  int has_unplug = 0;
  double error_rate = 0;
  for (int i = 1; i < argc; ++i) {
    const char* a = argv[i];
    const int more = i + 1 < argc;
    if (strcmp(a, "--baud") == 0 && more) {
      if (parse_u64(argv[++i], &baud) != 0) return usage();
    } else if (strcmp(a, "--seed") == 0 && more) {
      if (parse_u64(argv[++i], &seed) != 0) return usage();
    } else if (strcmp(a, "--error-rate") == 0 && more) {
      char* end = NULL;
      error_rate = strtod(argv[++i], &end);
      if (*end != '\0' || !(error_rate >= 0 && error_rate <= 1)) return usage();
    } else if (strcmp(a, "--unplug-at-ms") == 0 && more) {
      if (parse_u64(argv[++i], &unplug_at_ms) != 0) return usage();
      has_unplug = 1;
    } else if (strcmp(a, "--replug-after-ms") == 0 && more) {
      if (parse_u64(argv[++i], &replug_after_ms) != 0) return usage();
    } else if (strcmp(a, "--link") == 0 && more) {
      link = argv[++i];
    } else if (a[0] != '-' && !tty) {
      tty = a;
    } else {
      return usage();
    }
  }
  if (!tty) return usage();

  const int board = open(tty, O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (board < 0 || set_raw(board) != 0) {
    fprintf(stderr, "RELAY-TTY cannot open %s: %s\n", tty, strerror(errno));
    return 1;
  }
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_stop;
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGINT, &sa, NULL);
  signal(SIGPIPE, SIG_IGN);

  static direction to_board = {.name = "to_board"}, to_hub = {.name = "to_hub"};
  to_board.rng = seed * 2 + 1;
  to_hub.rng = seed * 2 + 2;
  const uint64_t byte_ns = baud > 0 ? 10000000000ull / baud : 0;
  uint64_t lost_unplugged = 0, unplugs = 0;

  hub_end hub = {-1, -1, ""};
  if (plug(&hub, link, stdout) != 0) {
    fprintf(stderr, "RELAY-PTY cannot open a pseudo-terminal: %s\n", strerror(errno));
    return 1;
  }
  const uint64_t start_ns = now_ns();
  uint64_t unplug_ns = has_unplug ? start_ns + unplug_at_ms * 1000000ull : 0;
  uint64_t replug_ns = 0;
  uint8_t chunk[4096];
  while (!stop_requested) {
    const uint64_t now = now_ns();
    if (unplug_ns && now >= unplug_ns) {
      unplug(&hub, link);
      ++unplugs;
      lost_unplugged += to_hub.len + to_board.len;
      to_hub.len = to_board.len = 0;
      unplug_ns = 0;
      replug_ns = now + replug_after_ms * 1000000ull;
    }
    if (replug_ns && now >= replug_ns) {
      replug_ns = 0;
      if (plug(&hub, link, stdout) != 0) {
        fprintf(stderr, "RELAY-PTY cannot open a pseudo-terminal: %s\n", strerror(errno));
        break;
      }
    }
    if (hub.master >= 0) {
      give(&to_board, board, byte_ns);
      give(&to_hub, hub.master, byte_ns);
    }

    struct pollfd fds[2];
    int nfds = 0;
    fds[nfds++] = (struct pollfd){board, room(&to_hub) > 0 ? POLLIN : 0, 0};
    if (hub.master >= 0) {
      short ev = room(&to_board) > 0 ? POLLIN : 0;
      if (to_hub.len > 0 && byte_ns == 0) ev |= POLLOUT;
      fds[nfds++] = (struct pollfd){hub.master, ev, 0};
      if (to_board.len > 0 && byte_ns == 0) fds[0].events |= POLLOUT;
    }
    int timeout_ms = 100;
    if (byte_ns > 0 && (to_board.len > 0 || to_hub.len > 0)) timeout_ms = 1;
    if (unplug_ns || replug_ns) timeout_ms = 5 < timeout_ms ? 5 : timeout_ms;
    const int r = poll(fds, (nfds_t)nfds, timeout_ms);
    if (r < 0 && errno != EINTR) break;
    if (r <= 0) continue;

    if (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) {
      const size_t max = room(&to_hub);
      const ssize_t n = read(board, chunk, max < sizeof chunk ? max : sizeof chunk);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) break; /* the board is gone */
      if (n > 0) {
        if (hub.master >= 0) {
          take(&to_hub, chunk, (size_t)n, error_rate);
        } else {
          to_hub.bytes += (uint64_t)n;
          lost_unplugged += (uint64_t)n;
        }
      }
    }
    if (nfds > 1 && (fds[1].revents & POLLIN)) {
      const size_t max = room(&to_board);
      const ssize_t n = read(hub.master, chunk, max < sizeof chunk ? max : sizeof chunk);
      if (n > 0) take(&to_board, chunk, (size_t)n, error_rate);
    }
  }
  if (link && hub.master >= 0) unlink(link);
  printf("RELAY");
  const direction* dirs[2] = {&to_board, &to_hub};
  for (int i = 0; i < 2; ++i) {
    printf(" %s bytes %llu dropped %llu flipped %llu inserted %llu", dirs[i]->name,
           (unsigned long long)dirs[i]->bytes, (unsigned long long)dirs[i]->dropped,
           (unsigned long long)dirs[i]->flipped, (unsigned long long)dirs[i]->inserted);
  }
  printf(" lost_unplugged %llu unplugs %llu\n", (unsigned long long)lost_unplugged,
         (unsigned long long)unplugs);
  fflush(stdout);
  return 0;
}
