// SPDX-License-Identifier: Apache-2.0
// How a hub link names and routes the far hub's channels (docs/hub-links.md): pure functions of
// what arrives over the link, kept apart so that a fuzz target drives them with any input.
#pragma once

#include <skrobot/runtime/flow/variant.h>

#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

// The name here of the far channel `remote_name`, seen over the link to hub `link_hub`:
// "<link_hub>/<remote_name>" for the far hub's own channels, the same name for a third hub's
// ("<hub>/<user>.<name>"), and "" for what is not taken: a name without a '.' after its hub
// prefix, or a channel of `own_hub` coming back.
[[nodiscard]] std::string linkedName(std::string_view remote_name, std::string_view link_hub,
                                     std::string_view own_hub);

// The hubs a far channel went through before reaching us: its property "hub_route" (a list of
// strings; anything else in it is skipped), and `link_hub` last.
[[nodiscard]] std::vector<std::string> hubRoute(const Variant& props, std::string_view link_hub);

// A far channel's properties as this hub shows them: `props` (a map; anything else is taken as
// none) with "hub_route" set to `route`.
[[nodiscard]] Variant routedProps(const Variant& props, const std::vector<std::string>& route);

// The number of links in a channel's "hub_route" property (0: not a linked hub's channel).
[[nodiscard]] size_t routeLength(const Variant& props);

// Whether a channel that came by `route` may be shown on `own_hub`: not when the route names it
// (a loop), nor when it is longer than `max_hops` links.
[[nodiscard]] bool routeAccepted(const std::vector<std::string>& route, std::string_view own_hub,
                                 size_t max_hops);

}  // namespace skr::flow
