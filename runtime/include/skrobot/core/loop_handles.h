// SPDX-License-Identifier: Apache-2.0
// moved to <skrobot/runtime/loop_handles.h>; this forwarding header goes in the next minor release
#pragma once
#include <skrobot/runtime/loop_handles.h>
