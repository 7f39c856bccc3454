/* SPDX-License-Identifier: Apache-2.0 */
/* Runs an Arduino Uno sketch (an ELF for the ATmega328P at 16 MHz) in simavr, its UART0 on a
 * pseudo-terminal, for the tests of the board library (tests/boards) and bench/serial_udp.
 *
 *   simavr_runner <sketch.elf> [--limit-ms N] [--reset-at-ms N] [--realtime]
 *
 * The first line on stdout is `PTY /dev/pts/N`: open that name as the board's serial port (each
 * runner has its own; simavr's fixed /tmp/simavr-uart0 link is not to be used, as several runners
 * may run at once). Runs until SIGTERM or SIGINT, or until --limit-ms of simulated time.
 * --reset-at-ms resets the MCU once at that simulated time, SIGUSR1 at the next step: the board
 * restarts from its reset vector while the line stays open. --realtime keeps simulated time from
 * running ahead of the wall clock (the board's millis() then follow the host's clock). At exit,
 * one line `SIM simulated <ms> ms in <ms> ms wall (<x>x) resets <n>` on stdout. simavr's own
 * messages go to stderr. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <avr_uart.h>
#include <parts/uart_pty.h>
#include <sim_avr.h>
#include <sim_elf.h>

#define F_CPU_HZ 16000000ull

static volatile sig_atomic_t stop_requested;
static volatile sig_atomic_t reset_requested;

static void on_stop(int sig) {
  (void)sig;
  stop_requested = 1;
}

static void on_reset(int sig) {
  (void)sig;
  reset_requested = 1;
}

static uint64_t now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static int usage(void) {
  fprintf(stderr,
          "usage: simavr_runner <sketch.elf> [--limit-ms N] [--reset-at-ms N] [--realtime]\n");
  return 2;
}

static int parse_ms(const char* text, uint64_t* out) {
  char* end = NULL;
  errno = 0;
  const unsigned long long v = strtoull(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0') return -1;
  *out = v;
  return 0;
}

/* The terminal side that the hub opens: raw from the start, so that nothing the board sends is
 * echoed back to it before the hub has set the port up. */
static int make_raw(const char* name) {
  const int fd = open(name, O_RDWR | O_NOCTTY);
  if (fd < 0) return -1;
  struct termios tio;
  int rc = tcgetattr(fd, &tio);
  if (rc == 0) {
    cfmakeraw(&tio);
    rc = tcsetattr(fd, TCSANOW, &tio);
  }
  close(fd);
  return rc;
}

int main(int argc, char** argv) {
  /* A test or benchmark that dies (an assertion, exit()) takes this process with it. */
  prctl(PR_SET_PDEATHSIG, SIGTERM);
  const char* elf = NULL;
  uint64_t limit_ms = 0, reset_at_ms = 0;
  int has_limit = 0, has_reset_at = 0, realtime = 0;
  for (int i = 1; i < argc; ++i) {
    if (strcmp(argv[i], "--limit-ms") == 0 && i + 1 < argc) {
      if (parse_ms(argv[++i], &limit_ms) != 0) return usage();
      has_limit = 1;
    } else if (strcmp(argv[i], "--reset-at-ms") == 0 && i + 1 < argc) {
      if (parse_ms(argv[++i], &reset_at_ms) != 0) return usage();
      has_reset_at = 1;
    } else if (strcmp(argv[i], "--realtime") == 0) {
      realtime = 1;
    } else if (argv[i][0] != '-' && !elf) {
      elf = argv[i];
    } else {
      return usage();
    }
  }
  if (!elf) return usage();

  /* simavr prints its set-up on stdout: it goes to stderr, so that our lines stand alone. */
  fflush(stdout);
  FILE* out = fdopen(dup(STDOUT_FILENO), "w");
  if (!out || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) return 1;

  elf_firmware_t firmware;
  memset(&firmware, 0, sizeof firmware);
  if (elf_read_firmware(elf, &firmware) != 0) {
    fprintf(stderr, "SIM-ELF cannot read %s\n", elf);
    return 1;
  }
  avr_t* avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) {
    fprintf(stderr, "SIM-MCU simavr has no atmega328p\n");
    return 1;
  }
  avr_init(avr);
  avr->frequency = (uint32_t)F_CPU_HZ;
  avr_load_firmware(avr, &firmware);

  static uart_pty_t pty;
  uart_pty_init(avr, &pty);
  uart_pty_connect(&pty, '0');
  /* simavr sleeps a microsecond (usleep: some 60 us on Linux) each time the firmware reads the
   * UART's status with nothing received or sent (AVR_UART_FLAG_POLL_SLEEP, on by default), as
   * the Arduino core does before each byte it writes: at 1,000,000 baud the simulator then fell
   * behind the wall clock (0.74x) and the board sent a tenth of what its line carries. Without
   * it, --realtime's pacing is what keeps the simulator from spinning ahead. */
  uint32_t uart_flags = 0;
  avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &uart_flags);
  uart_flags &= ~(uint32_t)AVR_UART_FLAG_POLL_SLEEP;
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &uart_flags);
  if (pty.port[0].s == 0 || pty.port[0].slavename[0] == '\0') {
    fprintf(stderr, "SIM-PTY no pseudo-terminal\n");
    return 1;
  }
  if (make_raw(pty.port[0].slavename) != 0) {
    fprintf(stderr, "SIM-PTY cannot set %s raw: %s\n", pty.port[0].slavename, strerror(errno));
    return 1;
  }
  fprintf(out, "PTY %s\n", pty.port[0].slavename);
  fflush(out);

  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_stop;
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGINT, &sa, NULL);
  sa.sa_handler = on_reset;
  sigaction(SIGUSR1, &sa, NULL);

  const uint64_t cycles_per_ms = F_CPU_HZ / 1000u;
  const uint64_t limit_cycles = has_limit ? limit_ms * cycles_per_ms : 0;
  const uint64_t reset_cycles = has_reset_at ? reset_at_ms * cycles_per_ms : 0;
  const uint64_t start_ns = now_ns();
  uint64_t next_pace = cycles_per_ms; /* --realtime: compare the clocks every simulated ms */
  unsigned resets = 0;
  int state = cpu_Running;
  while (!stop_requested) {
    if (reset_requested || (has_reset_at && avr->cycle >= reset_cycles)) {
      reset_requested = 0;
      has_reset_at = 0;
      avr_reset(avr);
      ++resets;
    }
    state = avr_run(avr);
    if (state == cpu_Done || state == cpu_Crashed) break;
    if (has_limit && avr->cycle >= limit_cycles) break;
    if (realtime && avr->cycle >= next_pace) {
      next_pace = avr->cycle + cycles_per_ms;
      const uint64_t sim_ns = avr->cycle * 1000u / (F_CPU_HZ / 1000000u);
      const uint64_t wall_ns = now_ns() - start_ns;
      if (sim_ns > wall_ns) {
        const uint64_t ahead = sim_ns - wall_ns;
        struct timespec ts = {(time_t)(ahead / 1000000000u), (long)(ahead % 1000000000u)};
        nanosleep(&ts, NULL);
      }
    }
  }
  const double wall_ms = (double)(now_ns() - start_ns) / 1e6;
  const double sim_ms = (double)avr->cycle / (double)cycles_per_ms;
  fprintf(out, "SIM simulated %.1f ms in %.1f ms wall (%.2fx) resets %u%s\n", sim_ms, wall_ms,
          wall_ms > 0 ? sim_ms / wall_ms : 0.0, resets,
          state == cpu_Crashed ? " crashed"
          : state == cpu_Done  ? " done"
                               : "");
  fflush(out);
  /* No uart_pty_stop(): it can wait forever for its thread (a SIGINT that lands outside its
   * select()); the process's exit ends the thread and closes the terminal. */
  return state == cpu_Crashed ? 1 : 0;
}
