// The hub's statistics: FlowServer::snapshot() reads the counters, statsBetween() turns two
// snapshots into rates, HubStats publishes them each second (flow/hub_stats.h).
#include <skrobot/core/log.h>
#include <skrobot/flow/hub_stats.h>

#include "server_impl.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

namespace skr::flow {

HubSnapshot FlowServer::snapshot() const {
  const Impl& s = *impl_;
  HubSnapshot out;
  out.at = monotonicNs();
  out.queue_limit = s.opt.subscriber_queue_bytes;
  s.channels.forEach([&](const Channel& ch) {
    ChannelCounters c;
    c.id = ch.id;
    c.name = ch.name;
    c.kind = ch.kind;
    c.mime = ch.mime;
    c.owner_flow = ch.owner != nullptr ? ch.owner->id : 0;
    for (const Endpoint* e : ch.subscribers) {
      if (e == nullptr) continue;
      c.subscriber_flows.push_back(e->id);
      c.subscriber_paths.emplace_back("relay");
    }
    for (const Endpoint* e : ch.physical) {  // on a path
      c.subscriber_flows.push_back(e->id);
      c.subscriber_paths.emplace_back(
          s.physical.activePath(ch.id, e->id) == msg::kPhysShm ? "shm" : "direct");
    }
    c.messages = ch.seq;
    c.bytes = ch.bytes;
    c.dropped = ch.dropped;
    c.pending_requests = static_cast<uint32_t>(ch.pending_requests);
    out.channels.push_back(std::move(c));
  });
  s.endpoints.forEach([&](const Endpoint& e) {
    FlowCounters f;
    f.id = e.id;
    f.user = e.user;
    f.client = e.client_name;
    f.kind = e.kind();
    f.messages_in = e.traffic.messages_in;
    f.bytes_in = e.traffic.bytes_in;
    f.messages_out = e.traffic.messages_out;
    f.bytes_out = e.traffic.bytes_out;
    f.dropped = e.traffic.dropped;
    f.path_messages = e.traffic.path_messages;
    f.path_bytes = e.traffic.path_bytes;
    f.queued_bytes = e.queuedBytes();
    f.pending_requests = e.pending_requests;
    out.flows.push_back(std::move(f));
  });
  std::sort(out.flows.begin(), out.flows.end(),
            [](const FlowCounters& a, const FlowCounters& b) { return a.id < b.id; });
  return out;
}

namespace {

// Per second, of a counter that went from `a` to `b` in `seconds` (a restarted one from zero).
// Rounded to 0.01: the figures are read by people and pages, and the JSON stays short.
double rate(uint64_t a, uint64_t b, double seconds) {
  if (seconds <= 0) return 0;
  return std::round(static_cast<double>(b >= a ? b - a : b) / seconds * 100) / 100;
}

int64_t wallMs() {
  using namespace std::chrono;
  return duration_cast<milliseconds>(system_clock::now().time_since_epoch()).count();
}

}  // namespace

Variant statsBetween(const HubSnapshot& before, const HubSnapshot& now,
                     const std::string& hub_name) {
  const double seconds = static_cast<double>(now.at - before.at) / 1e9;
  std::unordered_map<std::string, const ChannelCounters*> old_channels;
  for (const auto& c : before.channels) old_channels[c.name] = &c;
  std::unordered_map<uint32_t, const FlowCounters*> old_flows;
  for (const auto& f : before.flows) old_flows[f.id] = &f;
  std::unordered_map<uint32_t, std::string> flow_names;
  for (const auto& f : now.flows) flow_names[f.id] = f.user + "/" + f.client;

  Variant::List channels;
  for (const auto& c : now.channels) {
    static const ChannelCounters kNone;
    const auto it = old_channels.find(c.name);
    const ChannelCounters& o =
        it != old_channels.end() && it->second->id == c.id ? *it->second : kNone;
    Variant::List subscribers;
    for (uint32_t id : c.subscriber_flows) subscribers.emplace_back(static_cast<uint64_t>(id));
    Variant::List paths;
    for (const auto& p : c.subscriber_paths) paths.emplace_back(p);
    const auto owner = flow_names.find(c.owner_flow);
    channels.emplace_back(Variant::Map{
        {"name", c.name},
        {"kind", std::string(channelKindName(c.kind))},
        {"mime", c.mime},
        {"owner", owner != flow_names.end() ? owner->second : std::string()},
        {"owner_flow", static_cast<uint64_t>(c.owner_flow)},
        {"subscribers", static_cast<uint64_t>(c.subscriber_flows.size())},
        {"subscriber_flows", std::move(subscribers)},
        {"subscriber_paths", std::move(paths)},
        {"messages", c.messages},
        {"bytes", c.bytes},
        {"dropped", c.dropped},
        {"hz", rate(o.messages, c.messages, seconds)},
        {"bytes_per_s", rate(o.bytes, c.bytes, seconds)},
        {"dropped_per_s", rate(o.dropped, c.dropped, seconds)},
        {"pending_requests", static_cast<uint64_t>(c.pending_requests)},
    });
  }
  Variant::List flows;
  for (const auto& f : now.flows) {
    static const FlowCounters kNone;
    const auto it = old_flows.find(f.id);
    const FlowCounters& o = it != old_flows.end() ? *it->second : kNone;
    const bool queued = f.kind == "satellite" || f.kind == "link";
    flows.emplace_back(Variant::Map{
        {"id", static_cast<uint64_t>(f.id)},
        {"name", f.user + "/" + f.client},
        {"user", f.user},
        {"client", f.client},
        {"kind", f.kind},
        {"messages_in", f.messages_in},
        {"bytes_in", f.bytes_in},
        {"messages_out", f.messages_out},
        {"bytes_out", f.bytes_out},
        {"dropped", f.dropped},
        {"in_hz", rate(o.messages_in, f.messages_in, seconds)},
        {"out_hz", rate(o.messages_out, f.messages_out, seconds)},
        {"in_bytes_per_s", rate(o.bytes_in, f.bytes_in, seconds)},
        {"out_bytes_per_s", rate(o.bytes_out, f.bytes_out, seconds)},
        {"dropped_per_s", rate(o.dropped, f.dropped, seconds)},
        {"path_messages", f.path_messages},
        {"path_bytes", f.path_bytes},
        {"path_hz", rate(o.path_messages, f.path_messages, seconds)},
        {"queued_bytes", f.queued_bytes},
        {"queue_fill", queued && now.queue_limit > 0
                           ? std::round(static_cast<double>(f.queued_bytes) * 1000 /
                                        static_cast<double>(now.queue_limit)) /
                                 1000
                           : 0.0},
        {"pending_requests", static_cast<uint64_t>(f.pending_requests)},
    });
  }
  return Variant::Map{{"hub", hub_name},
                      {"time_ms", wallMs()},
                      {"interval_s", seconds},
                      {"channels", std::move(channels)},
                      {"flows", std::move(flows)}};
}

HubStats::HubStats(Loop& loop, FlowServer& server) : loop_(loop), server_(server) {
  LocalHandlers h;
  h.on_subscribers = [this](uint16_t chan, bool first) {
    if (chan != stats_chan_) return;
    watched_ = first;
    if (first) last_ = server_.snapshot();  // the first second published counts from now
  };
  h.on_request = [this](uint16_t chan, uint64_t request, const std::string& command,
                        const std::string& /*requester*/, const Variant& /*value*/) {
    if (command == "stats") {
      // Nobody follows hub.stats: the figures since they were last taken.
      if (!watched_) compute();
      (void)client_->respond(chan, request, current_);
    } else {
      (void)client_->respond(chan, request,
                             Variant::Map{{"error", "unknown command '" + command + "' (stats)"}});
    }
  };
  client_ = server_.attachLocal("hub", "statistics", std::move(h));
  auto stats =
      client_->createChannel("stats", ChannelKind::streaming, "application/json",
                             Variant::Map{{"period_ms", 1000}, {"doc", "docs/observability.md"}});
  auto inspect = client_->createChannel("inspect", ChannelKind::service, "application/json",
                                        Variant::Map{{"commands", "stats"}});
  if (!stats || !inspect) {
    log::error("hub", "HUB-STATS",
               "hub.stats, hub.inspect: " + (!stats ? stats.error() : inspect.error()).message);
  }
  stats_chan_ = stats ? *stats : 0;
  inspect_chan_ = inspect ? *inspect : 0;
  last_ = server_.snapshot();
  tick_ = loop_.addTickHandler(Tick::one_sec, [this] { everySecond(); });
}

HubStats::~HubStats() {
  loop_.removeTickHandler(tick_);
}

void HubStats::compute() {
  HubSnapshot now = server_.snapshot();
  current_ = statsBetween(last_, now, server_.hubName());
  last_ = std::move(now);
}

// Only while someone follows hub.stats: a hub with thousands of channels and nobody looking
// spends nothing on them.
void HubStats::everySecond() {
  if (!watched_) return;
  compute();
  (void)client_->publish(stats_chan_, variantToJsonText(current_));
}

}  // namespace skr::flow
