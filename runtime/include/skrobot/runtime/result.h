// SPDX-License-Identifier: Apache-2.0
// The hub's Result and Errc are the shared, header-only ones of the plugin API.
#pragma once

#include <skrobot/result.hpp>
