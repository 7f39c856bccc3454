/* SPDX-License-Identifier: Apache-2.0 */
/* The board library on POSIX (a Linux board, tests): a serial tty opened raw, and the skr_io of
 * skr_flow.h over a file descriptor, with a monotonic millisecond clock. */
#ifndef SKR_POSIX_H
#define SKR_POSIX_H

#include "skr_flow.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Opens `device` (a tty) non-blocking and raw (no echo, no line discipline, 8N1) at `baud`.
 * Returns the descriptor, or -1 with errno set (EINVAL: a baud rate termios does not know). */
int skr_posix_open_tty(const char* device, unsigned baud);

/* The skr_io over `fd` (non-blocking): read returns -1 when nothing waits; write waits while the
 * descriptor is full, and drops the rest when it stays full for 100 ms (a stopped line: the
 * session then notices the silence). */
typedef struct {
  int fd;
} skr_posix_ctx;
void skr_posix_io(skr_io* io, skr_posix_ctx* ctx, int fd);

uint32_t skr_posix_millis(void* ctx);

#ifdef __cplusplus
}
#endif

#endif /* SKR_POSIX_H */
