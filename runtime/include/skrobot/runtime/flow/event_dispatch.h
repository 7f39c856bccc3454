// SPDX-License-Identifier: Apache-2.0
// The client's side of the dispatch generated from the catalogue (catalogue.h): an event the hub
// sends on a flow (a row to_client, via flow or link_flow) is decoded and handed to the handler's
// overload for its message, so a client has no switch over codes of its own and a new event row
// without a handler does not compile.
//
//   struct Events {
//     void on(msg::EvData& m);            // one overload per event row
//     ...
//     void broken(const std::string& why);  // the body did not decode
//     void unexpected(uint8_t code);        // not an event of a flow (or not in the catalogue)
//   };
//   dispatchEvent(events, code, body, limits);
//
// The hub's side is core/src/flow/dispatch.cpp.
#pragma once

#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/messages.h>

#include <cstdint>
#include <string_view>

namespace skr::flow {

namespace detail {

template <Direction D, Via V, class M, class Handler>
void runEvent(Handler& h, std::string_view body, const DecodeLimits& limits) {
  if constexpr (D == Direction::to_client && (V == Via::flow || V == Via::link_flow)) {
    auto m = decode<M>(body, limits);
    if (!m) {
      h.broken(m.error().message);
      return;
    }
    h.on(m.value());
  } else {
    h.unexpected(static_cast<uint8_t>(M::code));
  }
}

}  // namespace detail

template <class Handler>
void dispatchEvent(Handler& h, uint8_t code, std::string_view body, const DecodeLimits& limits) {
  switch (code) {
#define SKR_FLOW_EVENT(value, name, minor, dir, via, family, message, reply)   \
  case value:                                                                  \
    detail::runEvent<Direction::dir, Via::via, msg::message>(h, body, limits); \
    return;
    SKR_FLOW_CATALOGUE(SKR_FLOW_EVENT)
#undef SKR_FLOW_EVENT
    default:
      h.unexpected(code);
  }
}

}  // namespace skr::flow
