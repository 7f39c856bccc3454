// SPDX-License-Identifier: Apache-2.0
// Names and routes of a linked hub's channels (see hub_route.h).
#include "families/links/hub_route.h"

#include <algorithm>

namespace skr::flow {

std::string linkedName(std::string_view remote_name, std::string_view link_hub,
                       std::string_view own_hub) {
  const size_t slash = remote_name.find('/');
  const size_t dot = remote_name.find('.');
  if (dot == std::string_view::npos || dot == 0) return {};
  if (slash == std::string_view::npos || slash > dot) {
    return std::string(link_hub) + "/" + std::string(remote_name);
  }
  // Another hub's channel, reached through this one: the same name here, unless it is ours.
  if (slash == 0 || slash + 1 == dot || remote_name.substr(0, slash) == own_hub) return {};
  return std::string(remote_name);
}

std::vector<std::string> hubRoute(const Variant& props, std::string_view link_hub) {
  std::vector<std::string> route;
  const Variant* r = props.find("hub_route");
  if (r != nullptr && r->asList() != nullptr) {
    for (const Variant& hop : *r->asList()) {
      if (const auto* s = hop.asString()) route.push_back(*s);
    }
  }
  route.emplace_back(link_hub);
  return route;
}

Variant routedProps(const Variant& props, const std::vector<std::string>& route) {
  Variant routed = props.isMap() ? props : Variant(Variant::Map{});
  Variant::List hops;
  for (const std::string& hop : route) hops.emplace_back(hop);
  (*routed.asMap())["hub_route"] = Variant(std::move(hops));
  return routed;
}

size_t routeLength(const Variant& props) {
  const Variant* r = props.find("hub_route");
  return r != nullptr && r->asList() != nullptr ? r->asList()->size() : 0;
}

bool routeAccepted(const std::vector<std::string>& route, std::string_view own_hub,
                   size_t max_hops) {
  return route.size() <= max_hops && std::find(route.begin(), route.end(), own_hub) == route.end();
}

}  // namespace skr::flow
