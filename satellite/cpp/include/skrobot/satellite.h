// SPDX-License-Identifier: Apache-2.0
// The C++ satellite library: everything a satellite includes.
//   find_package(skrobot_satellite) -> skrobot::satellite, or pkg-config skrobot-satellite.
// docs/cpp-satellites.md is the guide.
#pragma once

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/signal.h>
#include <skrobot/satellite/address.h>
#include <skrobot/satellite/satellite.h>
#include <skrobot/satellite/sketch.h>
#include <skrobot/satellite/sync_client.h>
