// SPDX-License-Identifier: Apache-2.0
// flowctl play: re-create the channels of an MCAP recording and publish its messages with the
// recorded timing (docs/recording.md). Foxglove image messages written by flowctl record become
// media frames again.
#include <skrobot/foxglove/images.h>
#include <skrobot/mcap/reader.h>
#include <skrobot/runtime/flow/name_pattern.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "mcap_mapping.h"
#include "session.h"

namespace flowctl {

namespace mcap = skr::mcap;
using skr::flow::Variant;

namespace {

// A message copied out of a file read streaming (a file without a summary).
struct OwnedMessage {
  uint16_t channel_id = 0;
  uint64_t log_time = 0;
  std::string data;
};

// A channel's properties from `log_time` on.
struct PropertyChange {
  uint64_t log_time = 0;
  std::string topic;
  Variant::Map properties;
};

// The messages of a recording in log-time order: chunk by chunk through the index, or, for a
// file cut short, all of them read at once.
class Messages {
 public:
  Messages(const mcap::Reader& reader, std::vector<mcap::ChunkIndex> chunks)
      : reader_(&reader), chunks_(std::move(chunks)) {
    std::stable_sort(chunks_.begin(), chunks_.end(), [](const auto& a, const auto& b) {
      return a.message_start_time < b.message_start_time;
    });
  }
  explicit Messages(std::vector<OwnedMessage> owned) : owned_(std::move(owned)) {
    std::stable_sort(owned_.begin(), owned_.end(),
                     [](const auto& a, const auto& b) { return a.log_time < b.log_time; });
  }
  // The next message (views valid until the next call), nullopt at the end, or an error.
  skr::Result<std::optional<mcap::Message>> next() {
    if (reader_ == nullptr) {
      if (at_ >= owned_.size()) return std::optional<mcap::Message>();
      const auto& m = owned_[at_++];
      return std::optional<mcap::Message>(mcap::Message{m.channel_id, 0, m.log_time, 0, m.data});
    }
    while (at_ >= current_.size()) {
      if (chunk_ >= chunks_.size()) return std::optional<mcap::Message>();
      auto messages = reader_->readChunk(chunks_[chunk_++], buffer_);
      if (!messages) return messages.error();
      current_ = std::move(messages).value();
      at_ = 0;
    }
    return std::optional<mcap::Message>(current_[at_++]);
  }
  void rewind() {
    at_ = 0;
    chunk_ = 0;
    current_.clear();
  }

 private:
  const mcap::Reader* reader_ = nullptr;
  std::vector<mcap::ChunkIndex> chunks_;
  size_t chunk_ = 0;
  std::string buffer_;
  std::vector<mcap::Message> current_;
  std::vector<OwnedMessage> owned_;
  size_t at_ = 0;
};

std::optional<PropertyChange> propertyChange(const mcap::Metadata& m) {
  if (m.name != mcapmap::kPropertiesName) return std::nullopt;
  auto get = [&](const char* key) -> std::string {
    auto it = m.metadata.find(key);
    return it == m.metadata.end() ? std::string() : it->second;
  };
  auto props = skr::flow::variantFromJsonText(get("properties"));
  if (!props || !props->isMap()) return std::nullopt;
  PropertyChange c;
  c.topic = get("channel");
  c.log_time = std::strtoull(get("log_time").c_str(), nullptr, 10);
  c.properties = *props->asMap();
  return c;
}

// The short name a recorded topic gets: after the hub prefix and the user.
std::string shortNameOf(std::string_view topic) {
  if (auto slash = topic.find('/'); slash != std::string_view::npos) topic.remove_prefix(slash + 1);
  if (auto dot = topic.find('.'); dot != std::string_view::npos) topic.remove_prefix(dot + 1);
  return std::string(topic);
}

}  // namespace

int cmdPlay(const Cli& cli) {
  Args args(cli.args);
  const auto rate_text = args.option("--rate");
  const bool loop = args.flag("--loop");
  const auto start_text = args.option("--start");
  const auto channels_text = args.option("--channels");
  const auto wait_text = args.option("--wait-ms");
  const auto sync_name = args.option("--sync");
  const auto sync_hz_text = args.option("--sync-hz");
  std::vector<std::string> remaps;
  while (auto r = args.option("--remap")) remaps.push_back(*r);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1) return usageError(cli);
  double rate = 1, start_s = 0, wait_ms = 1000;
  if (rate_text && !parseNumber(*rate_text, "--rate", rate)) return kUsage;
  if (start_text && !parseNumber(*start_text, "--start", start_s)) return kUsage;
  if (wait_text && !parseNumber(*wait_text, "--wait-ms", wait_ms)) return kUsage;
  if (!(rate > 0)) return fail(kUsage, "--rate must be above 0");
  double sync_hz = 0;
  if (sync_hz_text && !parseNumber(*sync_hz_text, "--sync-hz", sync_hz)) return kUsage;
  if (sync_name.has_value() != (sync_hz > 0)) {
    return fail(kUsage, "--sync NAME and --sync-hz HZ (above 0) go together");
  }
  std::vector<skr::flow::NamePattern> only;
  if (channels_text) {
    std::string_view list = *channels_text;
    while (!list.empty()) {
      const auto comma = list.find(',');
      auto p = skr::flow::NamePattern::parse(list.substr(0, comma));
      if (!p) return fail(kUsage, "--channels: " + p.error().message);
      only.push_back(std::move(p).value());
      list.remove_prefix(comma == std::string_view::npos ? list.size() : comma + 1);
    }
  }
  std::map<std::string, std::string> remap;  // recorded topic -> name here
  for (const auto& r : remaps) {
    const auto eq = r.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == r.size()) {
      return fail(kUsage, "--remap FROM=TO, not '" + r + "'");
    }
    remap[r.substr(0, eq)] = r.substr(eq + 1);
  }

  auto reader = mcap::Reader::open(rest[0]);
  if (!reader) return fail(kFailed, reader.error().message);
  std::map<uint16_t, mcap::Channel> channels;
  std::map<uint16_t, std::string> schema_names;
  std::vector<PropertyChange> changes;
  std::optional<Messages> messages;
  auto summary = reader->readSummary();
  if (summary && !summary->chunks.empty()) {
    channels = summary->channels;
    for (const auto& [id, schema] : summary->schemas) schema_names[id] = schema.name;
    for (const auto& index : summary->metadata) {
      if (index.name != mcapmap::kPropertiesName) continue;
      auto m = reader->readMetadata(index);
      if (!m) return fail(kFailed, rest[0] + ": " + m.error().message);
      if (auto c = propertyChange(*m)) changes.push_back(std::move(*c));
    }
    messages.emplace(*reader, summary->chunks);
  } else if (summary || summary.error().code == skr::Errc::not_found) {
    // No index, or messages outside chunks (which no index covers): read it all.
    std::vector<OwnedMessage> owned;
    auto end = reader->scan({.schema = [&](const mcap::Schema& x) { schema_names[x.id] = x.name; },
                             .channel = [&](const mcap::Channel& c) { channels[c.id] = c; },
                             .message =
                                 [&](const mcap::Message& m) {
                                   owned.push_back({m.channel_id, m.log_time, std::string(m.data)});
                                 },
                             .metadata =
                                 [&](const mcap::Metadata& m, uint64_t) {
                                   if (auto c = propertyChange(m)) changes.push_back(std::move(*c));
                                 }});
    if (!end) return fail(kFailed, rest[0] + ": " + end.error().message);
    if (!end->complete) {
      std::fprintf(stderr, "flowctl: %s has no index (%s): played as read\n", rest[0].c_str(),
                   end->stopped.c_str());
    }
    messages.emplace(std::move(owned));
  } else {
    return fail(kFailed, rest[0] + ": " + summary.error().message);
  }
  std::stable_sort(changes.begin(), changes.end(),
                   [](const auto& a, const auto& b) { return a.log_time < b.log_time; });

  // The channels to play and their names here.
  std::string me;
  {
    int code = kOk;
    auto sync = connectSync(cli, code);
    if (!sync) return code;
    me = sync->login().user;
  }
  struct Played {
    std::string topic, short_name, mime;
    uint16_t hub_id = 0;
    Variant::Map properties;
    uint64_t published = 0;
    bool image = false;  // Foxglove image messages: published as media frames
    uint64_t unreadable = 0;
  };
  std::map<uint16_t, Played> played;  // by MCAP channel id
  std::set<std::string> names;
  for (const auto& [id, c] : channels) {
    if (!only.empty() &&
        std::none_of(only.begin(), only.end(), [&](const auto& p) { return p.matches(c.topic); })) {
      continue;
    }
    std::string name = shortNameOf(c.topic);
    if (auto it = remap.find(c.topic); it != remap.end()) {
      name = it->second;
      if (name.find('.') != std::string::npos) {
        if (!name.starts_with(me + ".")) {
          return fail(kDenied, "--remap " + c.topic + "=" + name + ": you publish on " + me +
                                   ".<name> channels only");
        }
        name = name.substr(me.size() + 1);
      }
    }
    if (!skr::flow::validShortName(name)) {
      return fail(kUsage,
                  "cannot name a channel '" + name + "' (from " + c.topic + "): --remap it");
    }
    if (!names.insert(name).second) {
      return fail(kUsage,
                  "two recorded channels would both be " + me + "." + name + ": --remap one");
    }
    const auto schema = schema_names.find(c.schema_id);
    const bool image = c.message_encoding == "json" && schema != schema_names.end() &&
                       (schema->second == skr::foxglove::kRawImage ||
                        schema->second == skr::foxglove::kCompressedImage);
    played[id] = {c.topic, name, mcapmap::mimeOf(c), 0, {}, 0, image, 0};
  }
  if (played.empty()) return fail(kNotFound, "no channel of " + rest[0] + " to play");

  Session s(cli, skr::kNsPerMs);
  // A channel of that name exists: someone else publishes it (or an earlier play still runs).
  s.explain = [&](const sat::FlowError& e) {
    std::string why = e.message;
    if (static_cast<skr::flow::ErrorCode>(e.error) != skr::flow::ErrorCode::already_exists) {
      return why;
    }
    std::string example = "RECORDED=NAME";
    for (const auto& [id, p] : played) {
      if (e.message.find(me + "." + p.short_name + " ") != std::string::npos) {
        example = p.topic + "=" + p.short_name + "_replay";
      }
    }
    return why +
           ": another satellite publishes it; play the recording onto another channel with "
           "--remap " +
           example + " (flowctl help play)";
  };
  // Each channel starts with the properties it had when the first message to play was logged.
  for (auto& [id, p] : played) {
    for (const auto& c : changes) {
      if (c.topic == p.topic) {
        p.properties = c.properties;
        break;
      }
    }
    if (auto r =
            s.satellite.addChannel({.name = p.short_name, .mime = p.mime, .props = p.properties});
        !r) {
      return fail(kUsage, r.error().message);
    }
  }
  // A sync source pulsing on the recording's clock: HZ pulses per recorded second.
  if (sync_name) {
    if (auto r = s.satellite.addChannel({.name = *sync_name, .kind = skr::flow::ChannelKind::sync});
        !r) {
      return fail(kUsage, "--sync: " + r.error().message);
    }
  }
  uint64_t pulses = 0, pulse_k = 0;
  size_t ready = 0;
  s.satellite.channelReady.connect(&s.satellite, [&](const sat::ChannelInfo& info) {
    for (auto& [id, p] : played) {
      if (info.name == me + "." + p.short_name && p.hub_id == 0) {
        p.hub_id = info.id;
        ++ready;
      }
    }
  });

  // Schedule: a message logged at t is due at wall_start + (t - t0) / rate.
  const uint64_t skip_ns = static_cast<uint64_t>(std::max(start_s, 0.0) * 1e9);
  skr::Nanos ready_ns = 0, wall_start = 0;
  uint64_t t0 = 0, sent = 0, late_max_ns = 0, rounds = 0;
  size_t change_at = 0;
  std::optional<mcap::Message> pending;
  bool started = false, draining = false;
  skr::Nanos first_publish = 0;
  auto fetch = [&]() -> bool {
    while (true) {
      auto m = messages->next();
      if (!m) {
        s.end(kFailed, rest[0] + ": " + m.error().message);
        return false;
      }
      pending = *m;
      if (!pending) return true;
      if (played.count(pending->channel_id) == 0) continue;
      if (t0 == 0) t0 = pending->log_time + skip_ns;
      if (pending->log_time < t0) continue;
      return true;
    }
  };
  s.loop.addTickHandler(skr::Tick::fast, [&] {
    if (!s.satellite.isConnected() || ready < played.size()) return;
    const skr::Nanos now = skr::monotonicNs();
    if (!started) {
      if (ready_ns == 0) ready_ns = now;
      const bool everyone = std::all_of(played.begin(), played.end(), [&](const auto& p) {
        return s.satellite.hasSubscribers(p.second.short_name);
      });
      if (!everyone && now - ready_ns < static_cast<skr::Nanos>(wait_ms * 1e6)) return;
      started = true;
      if (!fetch()) return;
      wall_start = now;
      first_publish = now;
    }
    if (draining) {
      if (s.satellite.queuedBytes() == 0) s.loop.stop();
      return;
    }
    while (sync_name &&
           wall_start + static_cast<skr::Nanos>(double(pulse_k) * 1e9 / (sync_hz * rate)) <= now) {
      ++pulse_k;
      if (s.satellite.pulse(*sync_name)) ++pulses;
    }
    while (true) {
      if (!pending) {
        if (!loop) {
          draining = true;
          return;
        }
        ++rounds;
        messages->rewind();
        t0 = 0;
        change_at = 0;
        if (!fetch() || !pending) return s.end(kFailed, "nothing to play in " + rest[0]);
        wall_start = now;
        pulse_k = 0;
      }
      const auto due =
          wall_start + static_cast<skr::Nanos>(static_cast<double>(pending->log_time - t0) / rate);
      if (due > now) return;
      if (s.satellite.queuedBytes() > (16u << 20)) return;  // the hub is behind: wait
      late_max_ns = std::max<uint64_t>(late_max_ns, static_cast<uint64_t>(now - due));
      // Property changes logged up to this message.
      while (change_at < changes.size() && changes[change_at].log_time <= pending->log_time) {
        const auto& c = changes[change_at++];
        for (auto& [id, p] : played) {
          if (p.topic != c.topic || c.log_time < t0 || p.properties == c.properties) continue;
          Variant::Map diff = c.properties;
          for (const auto& [key, value] : p.properties) {
            if (c.properties.count(key) == 0) diff[key] = Variant();
          }
          (void)s.satellite.setChannelProperties(p.short_name, std::move(diff));
          p.properties = c.properties;
        }
      }
      auto& p = played.at(pending->channel_id);
      std::string frame;
      if (p.image) {
        auto made = skr::foxglove::mediaFrameOf(pending->data);
        if (!made) {
          if (p.unreadable++ == 0) {
            std::fprintf(stderr, "flowctl: PLAY-NOT-IMAGE %s: %s (skipped)\n", p.topic.c_str(),
                         made.error().message.c_str());
          }
          if (!fetch()) return;
          continue;
        }
        frame = std::move(made).value();
      }
      if (auto r = s.satellite.publish(p.hub_id, p.image ? std::string_view(frame) : pending->data);
          !r) {
        return s.end(kFailed, r.error().message);
      }
      ++p.published;
      ++sent;
      if (!fetch()) return;
    }
  });
  std::fprintf(stderr, "flowctl: playing %s on %zu channel%s as %s (Ctrl-C stops)\n",
               rest[0].c_str(), played.size(), played.size() == 1 ? "" : "s", me.c_str());
  const int code = s.run();
  const double seconds =
      first_publish == 0 ? 0 : static_cast<double>(skr::monotonicNs() - first_publish) / 1e9;
  if (cli.json) {
    Variant::List list;
    for (const auto& [id, p] : played) {
      list.emplace_back(Variant::Map{{"recorded", p.topic},
                                     {"name", me + "." + p.short_name},
                                     {"messages", p.published},
                                     {"unreadable", p.unreadable}});
    }
    std::printf("%s\n", skr::flow::variantToJsonText(
                            Variant::Map{{"messages", sent},
                                         {"seconds", seconds},
                                         {"loops", rounds},
                                         {"pulses", pulses},
                                         {"late_max_ms", static_cast<double>(late_max_ns) / 1e6},
                                         {"channels", std::move(list)}})
                            .c_str());
  } else if (code == kOk || sent > 0) {
    std::printf("played %llu messages on %zu channels in %.1f s (at worst %.1f ms late)\n",
                (unsigned long long)sent, played.size(), seconds,
                static_cast<double>(late_max_ns) / 1e6);
  }
  return code;
}

}  // namespace flowctl
