// SPDX-License-Identifier: Apache-2.0
// flowctl ls: the hub's channels, or those whose names match patterns.
#include <skrobot/runtime/flow/name_pattern.h>

#include <algorithm>

#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

// The linked hub a channel lives on ("arm" for "arm/guest.camera"), or "" for this hub's own.
std::string hubOf(const std::string& name) {
  const size_t slash = name.find('/');
  return slash == std::string::npos || slash > name.find('.') ? std::string()
                                                              : name.substr(0, slash);
}

Variant channelVariant(const skr::sat::ChannelInfo& c) {
  const auto kind = skr::flow::channelKindName(static_cast<skr::flow::ChannelKind>(c.kind));
  return Variant::Map{{"id", c.id},
                      {"hash", c.hash},
                      {"kind", std::string(kind)},
                      {"name", c.name},
                      {"hub", hubOf(c.name)},
                      {"owner", c.owner},
                      {"owner_connection", c.owner_connection},
                      {"mime", c.mime},
                      {"subscribers", c.subscribers},
                      {"props", c.props}};
}

}  // namespace

int cmdLs(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  auto filter = skr::flow::NameFilter::parse(rest.empty() ? std::vector<std::string>{"**"} : rest);
  if (!filter) return fail(kUsage, filter.error().message);
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto list = sync->channels();
  if (!list) return fail(exitFor(list.error()), list.error().message);
  std::vector<skr::sat::ChannelInfo> shown;
  for (auto& c : *list) {
    if (filter->selects(c.name)) shown.push_back(std::move(c));
  }
  if (cli.json) {
    Variant::List out;
    for (const auto& c : shown) out.push_back(channelVariant(c));
    std::printf("%s\n", skr::flow::variantToJsonText(out).c_str());
    return kOk;
  }
  if (shown.empty()) {
    std::printf("no channels\n");
    return kOk;
  }
  size_t name_w = 4, owner_w = 5, mime_w = 4, hub_w = 3;
  for (const auto& c : shown) {
    name_w = std::max(name_w, c.name.size());
    hub_w = std::max(hub_w, hubOf(c.name).size());
    owner_w = std::max(owner_w, c.owner.size() + 1 + std::to_string(c.owner_connection).size());
    mime_w = std::max(mime_w, c.mime.size());
  }
  std::printf("%-5s %-9s %-*s %-*s %-*s %4s  %-*s  %s\n", "ID", "KIND", int(hub_w), "HUB",
              int(name_w), "NAME", int(owner_w), "OWNER", "SUBS", int(mime_w), "MIME",
              "PROPERTIES");
  for (const auto& c : shown) {
    const std::string owner = c.owner + "#" + std::to_string(c.owner_connection);
    const std::string hub = hubOf(c.name);
    std::printf("%-5u %-9s %-*s %-*s %-*s %4u  %-*s  %s\n", c.id,
                std::string(skr::flow::channelKindName(static_cast<skr::flow::ChannelKind>(c.kind)))
                    .c_str(),
                int(hub_w), hub.empty() ? "-" : hub.c_str(), int(name_w), c.name.c_str(),
                int(owner_w), owner.c_str(), c.subscribers, int(mime_w), c.mime.c_str(),
                skr::flow::variantToJsonText(c.props).c_str());
  }
  return kOk;
}

}  // namespace flowctl
