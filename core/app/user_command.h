// SPDX-License-Identifier: Apache-2.0
// `skrobot user ...`: manage the hub's users file (docs/accounts.md).
#pragma once

// Runs `skrobot user add|del|passwd|list ...`; argv[0] is "user". Returns the process exit code:
// 0 done, 1 the operation failed (user exists, not found, file unreadable or unwritable, bad
// password), 2 usage. Reads the password from the terminal without echo (asked twice), or one
// line from stdin with --password-stdin or when stdin is not a terminal. Blocking; main thread.
int runUserCommand(int argc, char** argv);
