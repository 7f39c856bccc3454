// SPDX-License-Identifier: Apache-2.0
// The one switch over codes in the hub: generated from the catalogue, one case per row.
#include "dispatch.h"

#include "connection.h"
#include "hub.h"

#include <skrobot/runtime/flow/codec.h>

#include <algorithm>

namespace skr::flow {

namespace {

// One typed value in a command: a decoded Variant takes up to ~40 bytes of memory per input byte
// (a list of nulls), so values are bounded well below the frame limit. Payloads (PUBLISH,
// BLOB_CHUNK) are views into the frame and take the whole frame limit.
constexpr size_t kMaxValueBytes = 4u << 20;
// Blob requests carry paths and numbers, no large values.
constexpr size_t kMaxBlobValueBytes = 1u << 20;

DecodeLimits limitsOf(Family family, const ServerOptions& opt) {
  const size_t most = family == Family::blobs ? kMaxBlobValueBytes : kMaxValueBytes;
  return DecodeLimits{32, std::min<size_t>(opt.max_frame_bytes, most)};
}

// A row the hub receives: decode, then the room's handler. A row the hub only sends never gets
// here (handleFrame closed the connection).
template <Direction D, class M, class Room>
void run(Room& room, Connection& c, std::string_view body, const DecodeLimits& limits) {
  if constexpr (D == Direction::to_hub) {
    auto m = decode<M>(body, limits);
    if (!m) {
      c.protocolError(m.error().message);
      return;
    }
    room.handle(c, *m);
  } else {
    c.protocolError(std::string(codeName(uint8_t(M::code))) + " is not sent by satellites");
  }
}

}  // namespace

void dispatch(Hub& hub, Connection& c, uint8_t code, std::string_view body) {
  hub.loop.debugRequireLoopThread("flow::dispatch");
  switch (code) {
#define SKR_FLOW_DISPATCH(value, name, minor, dir, via, family, message, reply) \
  case value:                                                                   \
    return run<Direction::dir, msg::message>(hub.family, c, body,               \
                                             limitsOf(Family::family, hub.opt));
    SKR_FLOW_CATALOGUE(SKR_FLOW_DISPATCH)
#undef SKR_FLOW_DISPATCH
    default:
      c.protocolError("code " + std::to_string(code) + " is not in the catalogue");
  }
}

}  // namespace skr::flow
