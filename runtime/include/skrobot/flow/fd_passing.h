// SPDX-License-Identifier: Apache-2.0
// moved to <skrobot/runtime/flow/fd_passing.h>; this forwarding header goes in the next minor
// release
#pragma once
#include <skrobot/runtime/flow/fd_passing.h>
