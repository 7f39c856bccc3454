// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: what a linked hub sends about its channels. The bytes are an EV_CHAN_ADDED
// body (a ChannelInfo: the name and the properties come from the far hub); its name and route
// go through the link's naming and routing (core/src/flow/families/links/hub_route.cpp), whose
// promises are checked: a taken name keeps the far name, or prefixes it with the link's hub; never
// one of our own channels back; a route always ends with the link's hub.
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/messages.h>

#include "families/links/hub_route.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skr::flow;
  const std::string_view body(reinterpret_cast<const char*>(data), size);
  auto ev = decode<msg::EvChanAdded>(body, DecodeLimits{32, 1 << 20});
  if (!ev) return 0;
  const std::string& remote = ev->info.name;
  const std::string local = linkedName(remote, "bee", "ay");
  if (!local.empty()) {
    if (local.starts_with("ay/")) std::abort();  // ours, back
    if (local != remote && local != "bee/" + remote) std::abort();
    if (local.find('.') == std::string::npos) std::abort();
  }
  const auto route = hubRoute(ev->info.props, "bee");
  if (route.empty() || route.back() != "bee") std::abort();
  // What this hub shows keeps the route it came by, and its length is what routes compare.
  const Variant shown = routedProps(ev->info.props, route);
  if (routeLength(shown) != route.size() || hubRoute(shown, "x").size() != route.size() + 1) {
    std::abort();
  }
  if (routeAccepted(route, "ay", 8) &&
      (route.size() > 8 || std::find(route.begin(), route.end(), "ay") != route.end())) {
    std::abort();
  }
  return 0;
}
