// SPDX-License-Identifier: Apache-2.0
// The hub's statistics: FlowServer::sampleRates() closes a second of every channel's and flow's
// rate windows, FlowServer::snapshot() reads the counters and those windows, statsOf() writes
// them as hub.stats carries them, HubStats samples and publishes each second (flow/hub_stats.h).
#include <skrobot/hub/flow/hub_stats.h>
#include <skrobot/runtime/log.h>

#include "server_impl.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

namespace skr::flow {

namespace {

// Per second, of a counter that rose by `delta` in `span_ns` (0 when no time was covered).
// Rounded to 0.01: the figures are read by people and pages, and the JSON stays short.
double perSecond(uint64_t delta, Nanos span_ns) {
  if (span_ns <= 0) return 0;
  return std::round(static_cast<double>(delta) * 1e9 / static_cast<double>(span_ns) * 100) / 100;
}

double seconds(Nanos ns) {
  return std::round(static_cast<double>(ns) / 1e6) / 1000;  // to the millisecond
}

ChannelRates channelRates(const Channel::Rates::Window& w) {
  return {perSecond(w.delta[0], w.span_ns), perSecond(w.delta[1], w.span_ns),
          perSecond(w.delta[2], w.span_ns)};
}

FlowRates flowRates(const Endpoint::Rates::Window& w) {
  // Endpoint::rateCounters: messages and bytes in, messages and bytes out, dropped, path.
  return {perSecond(w.delta[0], w.span_ns), perSecond(w.delta[2], w.span_ns),
          perSecond(w.delta[1], w.span_ns), perSecond(w.delta[3], w.span_ns),
          perSecond(w.delta[4], w.span_ns), perSecond(w.delta[5], w.span_ns)};
}

int64_t wallMs() {
  using namespace std::chrono;
  return duration_cast<milliseconds>(system_clock::now().time_since_epoch()).count();
}

}  // namespace

void FlowServer::sampleRates() {
  Impl& s = *impl_;
  const Nanos now = s.opt.stats_clock();
  s.channels.forEach([&](Channel& ch) { ch.rates.sample(now, ch.rateCounters()); });
  s.endpoints.forEach([&](Endpoint& e) { e.rates.sample(now, e.rateCounters()); });
  s.rate_ticks.sample(now, {});
  s.rates_until_ms = wallMs();
}

HubSnapshot FlowServer::snapshot() const {
  const Impl& s = *impl_;
  HubSnapshot out;
  out.at = s.opt.stats_clock();
  out.interval_s = seconds(s.rate_ticks.over(1).span_ns);
  out.interval_10s_s = seconds(s.rate_ticks.over(RateWindow<0>::kLongest).span_ns);
  out.rates_until_ms = s.rates_until_ms;
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
      const Endpoint::RateCap cap = e->rateCap(ch.id);
      c.subscriber_max_hz.push_back(cap.max_hz);
      c.subscriber_skipped.push_back(cap.skipped);
    }
    for (const Endpoint* e : ch.physical) {  // on a path
      c.subscriber_flows.push_back(e->id);
      c.subscriber_paths.emplace_back(
          s.physical.activePath(ch.id, e->id) == msg::kPhysShm ? "shm" : "direct");
      c.subscriber_max_hz.push_back(0);  // a path is not capped
      c.subscriber_skipped.push_back(0);
    }
    c.messages = ch.seq;
    c.bytes = ch.bytes;
    c.dropped = ch.dropped;
    c.pending_requests = static_cast<uint32_t>(ch.pending_requests);
    c.last_1s = channelRates(ch.rates.over(1));
    c.last_10s = channelRates(ch.rates.over(Channel::Rates::kLongest));
    c.age_s = seconds(ch.rates.age());
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
    f.queue_bytes = e.queueLimitBytes();
    f.pending_requests = e.pending_requests;
    f.last_1s = flowRates(e.rates.over(1));
    f.last_10s = flowRates(e.rates.over(Endpoint::Rates::kLongest));
    f.age_s = seconds(e.rates.age());
    out.flows.push_back(std::move(f));
  });
  if (s.serial_ports) {
    for (auto& port : s.serial_ports->view()) {
      out.serial.push_back({port.device, port.open, port.in_session, port.stats});
    }
  }
  if (s.udp_port)
    out.udp = UdpCounters{s.udp_port->port(), s.udp_port->sessions(), s.udp_port->stats()};
  if (s.web_port) {
    out.web = s.web_port->stats();
    out.web->port = s.web_port->port();
  }
  std::sort(out.flows.begin(), out.flows.end(),
            [](const FlowCounters& a, const FlowCounters& b) { return a.id < b.id; });
  return out;
}

Variant statsOf(const HubSnapshot& snapshot, const std::string& hub_name) {
  std::unordered_map<uint32_t, std::string> flow_names;
  for (const auto& f : snapshot.flows) flow_names[f.id] = f.user + "/" + f.client;

  Variant::List channels;
  for (const auto& c : snapshot.channels) {
    Variant::List subscribers;
    for (uint32_t id : c.subscriber_flows) subscribers.emplace_back(static_cast<uint64_t>(id));
    Variant::List paths;
    for (const auto& p : c.subscriber_paths) paths.emplace_back(p);
    Variant::List max_hz;
    for (uint16_t hz : c.subscriber_max_hz) max_hz.emplace_back(static_cast<uint64_t>(hz));
    Variant::List skipped;
    for (uint64_t n : c.subscriber_skipped) skipped.emplace_back(n);
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
        {"subscriber_max_hz", std::move(max_hz)},
        {"subscriber_skipped", std::move(skipped)},
        {"messages", c.messages},
        {"bytes", c.bytes},
        {"dropped", c.dropped},
        {"hz", c.last_1s.hz},
        {"bytes_per_s", c.last_1s.bytes_per_s},
        {"dropped_per_s", c.last_1s.dropped_per_s},
        {"hz_10s", c.last_10s.hz},
        {"bytes_per_s_10s", c.last_10s.bytes_per_s},
        {"dropped_per_s_10s", c.last_10s.dropped_per_s},
        {"age_s", c.age_s},
        {"pending_requests", static_cast<uint64_t>(c.pending_requests)},
    });
  }
  Variant::List flows;
  for (const auto& f : snapshot.flows) {
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
        {"in_hz", f.last_1s.in_hz},
        {"out_hz", f.last_1s.out_hz},
        {"in_bytes_per_s", f.last_1s.in_bytes_per_s},
        {"out_bytes_per_s", f.last_1s.out_bytes_per_s},
        {"dropped_per_s", f.last_1s.dropped_per_s},
        {"path_messages", f.path_messages},
        {"path_bytes", f.path_bytes},
        {"path_hz", f.last_1s.path_hz},
        {"in_hz_10s", f.last_10s.in_hz},
        {"out_hz_10s", f.last_10s.out_hz},
        {"in_bytes_per_s_10s", f.last_10s.in_bytes_per_s},
        {"out_bytes_per_s_10s", f.last_10s.out_bytes_per_s},
        {"dropped_per_s_10s", f.last_10s.dropped_per_s},
        {"path_hz_10s", f.last_10s.path_hz},
        {"age_s", f.age_s},
        {"queued_bytes", f.queued_bytes},
        {"queue_bytes", f.queue_bytes},
        {"queue_fill", queued && f.queue_bytes > 0
                           ? std::round(static_cast<double>(f.queued_bytes) * 1000 /
                                        static_cast<double>(f.queue_bytes)) /
                                 1000
                           : 0.0},
        {"pending_requests", static_cast<uint64_t>(f.pending_requests)},
    });
  }
  Variant::List serial;
  for (const SerialCounters& p : snapshot.serial) {
    const transport::SerialStats& l = p.line;
    serial.emplace_back(Variant::Map{
        {"device", p.device},
        {"open", p.open},
        {"in_session", p.in_session},
        {"bytes_in", l.bytes_in},
        {"bytes_out", l.bytes_out},
        {"frames_in", l.frames_in},
        {"frames_out", l.frames_out},
        {"bad_check", l.bad_check},
        {"bad_framing", l.bad_framing},
        {"bad_version", l.bad_version},
        {"too_long", l.too_long},
        {"overrun", l.overrun},
        {"dropped_out", l.dropped_out},
        {"resyncs", l.resyncs()},
        {"sessions", l.sessions},
    });
  }
  Variant::Map out{{"hub", hub_name},
                   {"time_ms", wallMs()},
                   {"interval_s", snapshot.interval_s},
                   {"interval_10s_s", snapshot.interval_10s_s},
                   {"rates_until_ms", snapshot.rates_until_ms},
                   {"channels", std::move(channels)},
                   {"flows", std::move(flows)},
                   {"serial", std::move(serial)}};
  if (snapshot.web) {
    const WebCounters& w = *snapshot.web;
    out["web"] = Variant::Map{
        {"port", static_cast<uint64_t>(w.port)},
        {"requests", w.requests},
        {"files", w.files},
        {"not_found", w.not_found},
        {"upgrades", w.upgrades},
        {"endpoint_upgrades", w.endpoint_upgrades},
        {"tokens", w.tokens},
        {"refused_host", w.refused_host},
        {"refused_origin", w.refused_origin},
        {"refused", w.refused},
    };
  }
  if (snapshot.udp) {
    const transport::UdpStats& u = snapshot.udp->stats;
    out["udp"] = Variant::Map{
        {"port", static_cast<uint64_t>(snapshot.udp->port)},
        {"open_sessions", snapshot.udp->open_sessions},
        {"datagrams_in", u.datagrams_in},
        {"datagrams_out", u.datagrams_out},
        {"bytes_in", u.bytes_in},
        {"bytes_out", u.bytes_out},
        {"cookies_sent", u.cookies_sent},
        {"short_hello", u.short_hello},
        {"bad_cookie", u.bad_cookie},
        {"bad_mac", u.bad_mac},
        {"unknown_session", u.unknown_session},
        {"malformed", u.malformed},
        {"replayed", u.replayed},
        {"lost", u.lost},
        {"reordered", u.reordered},
        {"too_large", u.too_large},
        {"send_failed", u.send_failed},
        {"overrun", u.overrun},
        {"sessions", u.sessions},
        {"timeouts", u.timeouts},
    };
  }
  return out;
}

HubStats::HubStats(Loop& loop, FlowServer& server) : loop_(loop), server_(server) {
  LocalHandlers h;
  h.on_subscribers = [this](uint16_t chan, bool first) {
    if (chan == stats_chan_) watched_ = first;
  };
  h.on_request = [this](uint16_t chan, uint64_t request, const std::string& command,
                        const std::string& /*requester*/, const Variant& /*value*/) {
    if (command == "stats") {
      (void)client_->respond(chan, request, current());
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
  tick_ = loop_.addTickHandler(Tick::one_sec, [this] { everySecond(); });
}

HubStats::~HubStats() {
  loop_.removeTickHandler(tick_);
}

Variant HubStats::current() const {
  Variant out = statsOf(server_.snapshot(), server_.hubName());
  const LoopStats& l = loop_.stats();
  out.asMap()->emplace(
      "loop", Variant::Map{{"name", loop_.name()},
                           {"fast_rate_hz", std::round(l.fast_rate_hz * 100) / 100},
                           {"work_ratio_mean", std::round(l.work_ratio_mean * 1000) / 1000},
                           {"skipped_ticks", l.skipped_ticks},
                           {"late_wakeups", l.late_wakeups},
                           {"late_skipped_ticks", l.late_skipped_ticks},
                           {"load_warnings", l.load_warnings}});
  for (const auto& [key, read] : sections_) out.asMap()->emplace(key, read());
  return out;
}

void HubStats::addSection(const std::string& key, std::function<Variant()> read) {
  sections_[key] = std::move(read);
}

void HubStats::removeSection(const std::string& key) noexcept {
  sections_.erase(key);
}

// Every second the rate windows move on, whoever reads them; the snapshot and its JSON only
// while someone follows hub.stats.
void HubStats::everySecond() {
  server_.sampleRates();
  if (watched_) (void)client_->publish(stats_chan_, variantToJsonText(current()));
}

}  // namespace skr::flow
