// SPDX-License-Identifier: Apache-2.0
#include "robot_backend.h"

namespace skr::nao {

const char* stateName(StateKind k) noexcept {
  switch (k) {
    case StateKind::joints:
      return "joints";
    case StateKind::sonar:
      return "sonar";
    case StateKind::battery:
      return "battery";
    case StateKind::posture:
      return "posture";
    case StateKind::fall:
      return "fall";
  }
  return "?";
}

}  // namespace skr::nao
