// SPDX-License-Identifier: Apache-2.0
// flowctl mcap info|cat: what an MCAP file holds, read here (no hub needed).
#include <skrobot/mcap/reader.h>

#include <map>

#include "cli.h"
#include "mcap_mapping.h"

namespace flowctl {

namespace mcap = skr::mcap;
using skr::flow::Variant;

namespace {

int info(const Cli& cli, const mcap::Reader& reader, const std::string& path) {
  struct Count {
    uint64_t messages = 0, bytes = 0;
  };
  std::map<uint16_t, mcap::Channel> channels;
  std::map<uint16_t, Count> counts;
  mcap::Header header;
  uint64_t messages = 0, first = 0, last = 0, metadata = 0, properties = 0;
  auto end = reader.scan({.header = [&](const mcap::Header& h) { header = h; },
                          .channel = [&](const mcap::Channel& c) { channels[c.id] = c; },
                          .message =
                              [&](const mcap::Message& m) {
                                first = messages == 0 ? m.log_time : std::min(first, m.log_time);
                                last = std::max(last, m.log_time);
                                ++messages;
                                ++counts[m.channel_id].messages;
                                counts[m.channel_id].bytes += m.data.size();
                              },
                          .metadata =
                              [&](const mcap::Metadata& m, uint64_t) {
                                ++metadata;
                                if (m.name == mcapmap::kPropertiesName) ++properties;
                              }});
  if (!end) return fail(kFailed, path + ": " + end.error().message);
  // The index, checked against what was read.
  std::string indexed = "no";
  std::map<std::string, uint64_t> compressions;
  if (auto summary = reader.readSummary()) {
    indexed = "yes";
    for (const auto& c : summary->chunks)
      ++compressions[c.compression.empty() ? "none" : c.compression];
    if (summary->statistics && summary->statistics->message_count != messages) {
      return fail(kFailed, path + ": the statistics count " +
                               std::to_string(summary->statistics->message_count) +
                               " messages, the file holds " + std::to_string(messages));
    }
  } else if (summary.error().code != skr::Errc::not_found) {
    return fail(kFailed, path + ": " + summary.error().message);
  }
  if (cli.json) {
    Variant::List list;
    for (const auto& [id, c] : channels) {
      list.emplace_back(Variant::Map{{"id", uint64_t(id)},
                                     {"topic", c.topic},
                                     {"encoding", c.message_encoding},
                                     {"mime", mcapmap::mimeOf(c)},
                                     {"messages", counts[id].messages},
                                     {"bytes", counts[id].bytes}});
    }
    Variant::Map comp;
    for (const auto& [k, n] : compressions) comp[k] = n;
    std::printf("%s\n", skr::flow::variantToJsonText(Variant::Map{{"file", path},
                                                                  {"complete", end->complete},
                                                                  {"stopped", end->stopped},
                                                                  {"indexed", indexed == "yes"},
                                                                  {"library", header.library},
                                                                  {"profile", header.profile},
                                                                  {"messages", messages},
                                                                  {"start_ns", first},
                                                                  {"end_ns", last},
                                                                  {"chunks", std::move(comp)},
                                                                  {"metadata", metadata},
                                                                  {"property_records", properties},
                                                                  {"channels", std::move(list)}})
                            .c_str());
    return kOk;
  }
  std::printf("file:      %s (%s)\n", path.c_str(),
              end->complete ? "complete" : ("cut short: " + end->stopped).c_str());
  std::printf("library:   %s\nindexed:   %s\n", header.library.c_str(), indexed.c_str());
  std::printf("messages:  %llu over %.3f s\n", (unsigned long long)messages,
              static_cast<double>(last - first) / 1e9);
  for (const auto& [k, n] : compressions) {
    std::printf("chunks:    %llu %s\n", (unsigned long long)n, k.c_str());
  }
  std::printf("metadata:  %llu (%llu channel property records)\nchannels:\n",
              (unsigned long long)metadata, (unsigned long long)properties);
  for (const auto& [id, c] : channels) {
    std::printf("  %5u  %-32s %-24s %8llu messages %12llu bytes\n", id, c.topic.c_str(),
                c.message_encoding.c_str(), (unsigned long long)counts[id].messages,
                (unsigned long long)counts[id].bytes);
  }
  return kOk;
}

// One JSON line per message, in file order.
int cat(const mcap::Reader& reader, const std::string& path) {
  std::map<uint16_t, std::string> topics;
  auto end = reader.scan({.channel = [&](const mcap::Channel& c) { topics[c.id] = c.topic; },
                          .message =
                              [&](const mcap::Message& m) {
                                Variant data = skr::flow::isValidUtf8(m.data)
                                                   ? Variant(std::string(m.data))
                                                   : Variant(Variant::Bytes(std::string(m.data)));
                                const std::string line = skr::flow::variantToJsonText(Variant::Map{
                                                             {"topic", topics[m.channel_id]},
                                                             {"sequence", uint64_t(m.sequence)},
                                                             {"log_time", m.log_time},
                                                             {"publish_time", m.publish_time},
                                                             {"data", std::move(data)}}) +
                                                         "\n";
                                std::fwrite(line.data(), 1, line.size(), stdout);
                              }});
  if (!end) return fail(kFailed, path + ": " + end.error().message);
  if (!end->complete) std::fprintf(stderr, "flowctl: %s: %s\n", path.c_str(), end->stopped.c_str());
  return kOk;
}

}  // namespace

int cmdMcap(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 2 || (rest[0] != "info" && rest[0] != "cat")) return usageError(cli);
  auto reader = mcap::Reader::open(rest[1]);
  if (!reader) return fail(kFailed, reader.error().message);
  return rest[0] == "info" ? info(cli, *reader, rest[1]) : cat(*reader, rest[1]);
}

}  // namespace flowctl
