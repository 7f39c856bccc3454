// SPDX-License-Identifier: Apache-2.0
// flowctl: reading the hub's statistics (hub.stats, hub.inspect; docs/observability.md), shared
// by top, info, graph, hz and bw.
#pragma once

#include <string>
#include <string_view>

#include "cli.h"

namespace flowctl::hubstats {

using skr::flow::Variant;

// A key of a map Variant: the value, or null (0, "", an empty list) when it is absent.
const Variant& at(const Variant& v, std::string_view key);
double num(const Variant& v, std::string_view key);
std::string str(const Variant& v, std::string_view key);
const Variant::List& list(const Variant& v, std::string_view key);
// The path the k-th of a channel's subscriber_flows takes: relay, direct or shm ("" from a hub
// that does not say).
std::string subscriberPath(const Variant& channel, size_t k);
// Bytes for people: "512 B", "1.5 KiB", ...
std::string human(double bytes);
// The hub's statistics asked of hub.inspect (rates over the last second and the last ten, the
// same for every reader until the hub's next one-second tick); nullopt (after the error, with
// `code` set) when the hub has none.
std::optional<Variant> fetchStats(const Cli& cli, int& code);

}  // namespace flowctl::hubstats
