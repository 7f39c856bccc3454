// SPDX-License-Identifier: Apache-2.0
// A hub link subscribes over there to exactly what is subscribed here, whatever order channels,
// subscribers and links come and go in (docs/hub-links.md, "What crosses a link").
//
// Two or three hubs run in this process on one loop, linked through relays (unix_relay.h) that a
// step may cut and restore; hub B may mirror A's channel (a replica). Publishers are in-process
// clients, subscribers in-process clients or satellites on a hub's socket. After each step, once
// every hub shows what the model says it should (the channels, each by the shortest route, and
// the subscribers), service calls from every hub to every other and from every satellite to its
// hub flush what the connections carry; then, twice in a row, for every link the channels it
// subscribes to on the far hub must be exactly those whose copy here has subscribers, every
// publisher must have been told whether it has any, and the replica must subscribe to its source
// exactly while it has subscribers.
//
// LINK_DEMAND_SEQUENCES=n runs n random sequences (default 200); LINK_DEMAND_SEED=s starts at
// seed s (and runs 1 sequence unless LINK_DEMAND_SEQUENCES says more). A failure prints the
// seed, the hubs and links, the steps, what differs, every hub's channels and the last log lines.
#include "temp_dir.h"
#include "unix_relay.h"

#include <skrobot/hub/flow/hub_stats.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/satellite/satellite.h>

#include <gtest/gtest.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace skr::flow {
namespace {

constexpr int kNames = 2;         // channels c0 and c1 on each hub
constexpr int kReplica = kNames;  // Step::name of B's replica hub.r0 of A/guest.c0
constexpr Nanos kSettleNs = 10 * kNsPerSec;
constexpr Nanos kDemandNs = 2 * kNsPerSec;

struct Step {
  // recreate: removed and created again twice at once, as by a publisher that restarts and
  // restarts again before anything reached the other hubs.
  enum Kind { create, remove, recreate, join, leave, cut, restore } kind = create;
  int hub = 0;          // the channel's hub; join: the subscriber's; cut, restore: one end
  int other = 0;        // join: the channel's hub; cut, restore: the other end
  int name = 0;         // create, remove, recreate, join: c<name>, or kReplica (join, on B)
  int sub = 0;          // leave: the subscriber (in the order they joined)
  bool abrupt = false;  // (re)move, leave: the client goes instead of removing or unsubscribing
  bool socket = false;  // join: a satellite on the hub's socket, not an in-process client
};

// Who lists whom: lists[i][j], hub i has a link to hub j. Both: one shared connection.
struct Topology {
  int hubs = 2;
  bool lists[3][3] = {};
  bool replica = false;  // B mirrors A/guest.c0 as hub.r0 (its config's "replicas")
};

const char* const kHubNames[] = {"A", "B", "C"};

// A channel's name on its own hub.
std::string localName(int name) {
  return name == kReplica ? "hub.r0" : "guest.c" + std::to_string(name);
}

std::string text(const Step& s) {
  const std::string h = kHubNames[s.hub], o = kHubNames[s.other];
  const std::string c = localName(s.name);
  switch (s.kind) {
    case Step::create:
      return "create " + h + ":" + c;
    case Step::remove:
      return "remove " + h + ":" + c + (s.abrupt ? " (its publisher goes)" : "");
    case Step::recreate:
      return "recreate " + h + ":" + c + " twice" + (s.abrupt ? " (new publishers)" : "");
    case Step::join:
      return "sub" + std::to_string(s.sub) + (s.socket ? " (a satellite)" : "") + " on " + h +
             " subscribes to " + (s.hub == s.other ? "" : o + "/") + c;
    case Step::leave:
      return "sub" + std::to_string(s.sub) + (s.abrupt ? " goes" : " unsubscribes");
    case Step::cut:
      return "cut " + h + "-" + o;
    case Step::restore:
      return "restore " + h + "-" + o;
  }
  return "?";
}

std::string text(const Topology& t) {
  std::string out;
  for (int i = 0; i < t.hubs; ++i) {
    for (int j = i + 1; j < t.hubs; ++j) {
      const bool ij = t.lists[i][j], ji = t.lists[j][i];
      if (!ij && !ji) continue;
      out += std::string(out.empty() ? "" : ", ") + kHubNames[ij ? i : j] +
             (ij && ji ? "<->" : "->") + kHubNames[ij ? j : i];
    }
  }
  return std::to_string(t.hubs) + " hubs, " + (out.empty() ? "no links" : out) +
         (t.replica ? ", B mirrors A/guest.c0 as hub.r0" : "");
}

// The log lines of the sequence under way, for a failure's report; nothing on the terminal.
class LogSink {
 public:
  LogSink() : null_(::open("/dev/null", O_WRONLY | O_CLOEXEC)) {
    log::setFd(null_);
    log::setHook(&LogSink::hook, this);
  }
  ~LogSink() {
    log::setHook(nullptr, nullptr);
    log::setFd(STDERR_FILENO);
    ::close(null_);
  }
  LogSink(const LogSink&) = delete;
  LogSink& operator=(const LogSink&) = delete;
  LogSink(LogSink&&) = delete;
  LogSink& operator=(LogSink&&) = delete;
  void clear() { lines_.clear(); }
  [[nodiscard]] std::string last(size_t n) const {
    std::string out;
    for (size_t i = lines_.size() > n ? lines_.size() - n : 0; i < lines_.size(); ++i) {
      out += "  " + lines_[i] + "\n";
    }
    return out;
  }

 private:
  static void hook(log::Level, std::string_view, std::string_view tag, std::string_view msg,
                   void* self) {
    static_cast<LogSink*>(self)->lines_.push_back(std::string(tag) + " " + std::string(msg));
  }
  int null_;
  std::vector<std::string> lines_;  // one thread: every hub runs on the test's loop
};

// The hubs of one sequence, with what the test made on them.
class Network {
 public:
  explicit Network(const Topology& t) : topo_(t) {
    for (int i = 0; i < t.hubs; ++i) {
      hubs_.push_back(std::make_unique<Hub>());
      hubs_.back()->name = kHubNames[i];
    }
    for (int i = 0; i < t.hubs; ++i) {
      for (int j = 0; j < t.hubs; ++j) {
        if (!t.lists[i][j]) continue;
        auto relay = std::make_unique<test::UnixRelay>(
            loop_, sock(std::to_string(i) + std::to_string(j)), sock(kHubNames[j]));
        EXPECT_TRUE(relay->open());
        relays_[{i, j}] = std::move(relay);
        up_[i][j] = up_[j][i] = true;
      }
    }
    // The hubs a hub links to first, where the links allow it: fewer retries.
    std::vector<int> order;
    for (int i = 0; i < t.hubs; ++i) order.push_back(i);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return t.lists[b][a] && !t.lists[a][b]; });
    for (int i : order) start(i);
  }

  ~Network() {
    subs_.clear();
    left_.clear();
    owners_.clear();
    for (auto& h : hubs_) h->ping.reset(), h->caller.reset();
    relays_.clear();
    for (auto& h : hubs_) h->server.reset();
    loop_.runUntil([] { return test::UnixRelay::liveHandles() == 0; }, kNsPerSec);
  }
  Network(const Network&) = delete;
  Network& operator=(const Network&) = delete;
  Network(Network&&) = delete;
  Network& operator=(Network&&) = delete;

  [[nodiscard]] bool exists(int hub, int name) const { return owners_.contains({hub, name}); }

  void apply(const Step& s) {
    switch (s.kind) {
      case Step::create:
        create(s.hub, s.name);
        break;
      case Step::remove:
        remove(s.hub, s.name, s.abrupt);
        break;
      case Step::recreate:
        for (int i = 0; i < 2; ++i) {
          remove(s.hub, s.name, s.abrupt);
          create(s.hub, s.name);
        }
        break;
      case Step::join:
        join(s);
        break;
      case Step::leave: {
        auto it = subs_.find(s.sub);
        Sub& sub = *it->second;
        if (!s.abrupt) {  // it stays, subscribed to nothing
          if (sub.local) sub.local->unsubscribe(sub.name);
          if (sub.sat) sub.sat->unsubscribe(sub.name);
          left_.push_back(std::move(it->second));
        }
        subs_.erase(it);
        break;
      }
      case Step::cut:
      case Step::restore:
        for (auto [a, b] : {std::pair{s.hub, s.other}, std::pair{s.other, s.hub}}) {
          auto it = relays_.find({a, b});
          if (it == relays_.end()) continue;
          if (s.kind == Step::cut) {
            it->second->cut();
          } else {
            it->second->restore();
          }
        }
        up_[s.hub][s.other] = up_[s.other][s.hub] = s.kind == Step::restore;
        break;
    }
  }

  // Empty when every hub shows what it should and every link carries exactly the demand behind
  // it; else what differs.
  std::string settle() {
    std::string why;
    const Nanos settle_by = monotonicNs() + kSettleNs;
    if (!loop_.runUntil([&] { return named() && attached(); }, kSettleNs)) {
      why = shown(views());
      return "the hubs do not show what they should: " +
             (why.empty() ? "a satellite is not subscribed" : why);
    }
    // Right twice in a row, each time after every link was flushed: what a hub does on hearing
    // from another (a withdrawn offer, say) may still be on its way after the first.
    const Nanos demand_by = std::min(settle_by, monotonicNs() + kDemandNs);
    int right = 0;
    do {
      if (why = barrier(); !why.empty()) return "the barrier: " + why;
      const std::vector<View> now = views();
      why = shown(now);
      why = why.empty() ? demand(now) : "the hubs do not show what they should: " + why;
      if (!why.empty()) {
        right = 0;
        loop_.runFor(kNsPerMs);
      } else if (++right == 2) {
        return {};
      }
    } while (monotonicNs() < demand_by);
    return why;
  }

  // Every hub's channels: owner and subscribers.
  [[nodiscard]] std::string dump() {
    std::string out;
    const std::vector<View> all = views();
    for (size_t h = 0; h < hubs_.size(); ++h) {
      const View& v = all[h];
      out += "  hub " + hubs_[h]->name + ":\n";
      for (const auto& [name, ch] : v.channels) {
        if (name.ends_with("guest.ping")) continue;
        out += "    " + name + " from " + v.clientOf(ch.owner_flow) + "; subscribers:";
        for (uint32_t f : ch.subscriber_flows) out += " [" + v.clientOf(f) + "]";
        out += "\n";
      }
    }
    return out;
  }

 private:
  struct Hub {
    std::string name;
    std::unique_ptr<FlowServer> server;
    std::unique_ptr<LocalClient> ping;    // owns guest.ping: answers every call at once
    std::unique_ptr<LocalClient> caller;  // calls the other hubs' guest.ping (barrier())
  };
  struct Owner {
    std::unique_ptr<LocalClient> client;
    uint16_t id = 0;
    bool told = false;  // first subscriber told, last not yet
    std::string wrong;  // a first after a first, or a last after a last
  };
  struct Sub {
    int hub = 0;
    std::string name;   // as the subscriber's hub names it
    std::string label;  // its client's name: sub<n>
    std::unique_ptr<LocalClient> local;
    std::unique_ptr<sat::Satellite> sat;
  };
  // One hub at one moment: channels by name, flows by id.
  struct View {
    std::map<std::string, ChannelCounters> channels;
    std::map<uint32_t, FlowCounters> flows;
    [[nodiscard]] std::string clientOf(uint32_t flow) const {
      auto it = flows.find(flow);
      return it == flows.end() ? "#" + std::to_string(flow) : it->second.client;
    }
    // The hub a link flow stands for ("hub link B" here, or the connection "hub B" of B's own
    // link), -1 for any other flow.
    [[nodiscard]] int linkTo(uint32_t flow) const {
      auto it = flows.find(flow);
      if (it == flows.end()) return -1;
      for (int h = 0; h < 3; ++h) {
        const std::string n = kHubNames[h];
        if (it->second.client == "hub link " + n || it->second.client == "hub " + n) return h;
      }
      return -1;
    }
  };

  std::string sock(const std::string& name) const {
    return (dir_.path() / (name + ".sock")).string();
  }

  void start(int i) {
    Hub& h = *hubs_[i];
    ServerOptions o;
    o.app_name = "skrobot-link-demand-" + std::to_string(::getpid()) + "-" + h.name;
    o.hub_name = h.name;
    o.unix_path = sock(h.name);
    o.users_file = dir_.path() / ("users-" + h.name + ".json");  // none: the dev account only
    o.dev_account = std::make_pair(std::string("guest"), std::string("password"));
    for (int j = 0; j < topo_.hubs; ++j) {
      if (!topo_.lists[i][j]) continue;
      HubLinkOptions l;
      l.name = kHubNames[j];
      l.address = "local:" + sock(std::to_string(i) + std::to_string(j));
      l.user = "guest";
      l.password = "password";
      o.links.push_back(l);
    }
    if (i == 1 && topo_.replica) o.replicas.push_back({"A/guest.c0", "r0"});
    h.server = std::make_unique<FlowServer>(loop_, o);
    auto started = h.server->start();
    ASSERT_TRUE(started) << started.error().message;
    LocalHandlers ph;
    ph.on_request = [&h](uint16_t chan, uint64_t request, const std::string&, const std::string&,
                         const Variant&) { (void)h.ping->respond(chan, request, Variant("pong")); };
    h.ping = h.server->attachLocal("guest", "ping", std::move(ph));
    ASSERT_TRUE(h.ping->createChannel("ping", ChannelKind::service, "text/plain", Variant::Map{}));
    LocalHandlers ch;
    ch.on_response = [this](uint16_t, uint32_t tag, Errc, const Variant&) { calls_.erase(tag); };
    h.caller = h.server->attachLocal("guest", "caller", std::move(ch));
  }

  void create(int hub, int name) {
    auto o = std::make_unique<Owner>();
    Owner* raw = o.get();
    LocalHandlers h;
    h.on_subscribers = [raw](uint16_t, bool first) {
      if (first == raw->told) raw->wrong = first ? "told first twice" : "told last twice";
      raw->told = first;
    };
    o->client = hubs_[hub]->server->attachLocal("guest", "publisher", std::move(h));
    auto id = o->client->createChannel("c" + std::to_string(name), ChannelKind::streaming,
                                       "application/octet-stream", Variant::Map{});
    ASSERT_TRUE(id) << id.error().message;
    o->id = *id;
    owners_[{hub, name}] = std::move(o);
  }

  void remove(int hub, int name, bool abrupt) {
    auto it = owners_.find({hub, name});
    if (!abrupt) {
      EXPECT_TRUE(it->second->client->removeChannel(it->second->id));
    }
    owners_.erase(it);
  }

  void join(const Step& s) {
    auto sub = std::make_unique<Sub>();
    sub->hub = s.hub;
    sub->name = nameOn(s.hub, s.other, localName(s.name));
    sub->label = "sub" + std::to_string(s.sub);
    if (s.socket) {
      sat::SatelliteOptions o;
      o.connection.address = Address::parse("local:" + sock(kHubNames[s.hub])).value();
      o.connection.client_name = sub->label;
      sub->sat = std::make_unique<sat::Satellite>(loop_, std::move(o));
      sub->sat->subscribe(sub->name);
      sub->sat->start();
    } else {
      sub->local = hubs_[s.hub]->server->attachLocal("guest", sub->label, {});
      ASSERT_TRUE(sub->local->subscribe(sub->name));
    }
    subs_[s.sub] = std::move(sub);
  }

  static std::string nameOn(int hub, int origin, const std::string& local) {
    return hub == origin ? local : std::string(kHubNames[origin]) + "/" + local;
  }

  // B shows its replica: it shows the source.
  [[nodiscard]] bool mirrored() const {
    return topo_.replica && exists(0, 0) && nextHop(0, 1) >= 0;
  }

  // Channels of `from` come to `to` (to lists from, and the link is up).
  [[nodiscard]] bool flows(int from, int to) const {
    return from != to && topo_.lists[to][from] && up_[from][to];
  }
  // The hub that brings `hub` the channels of `origin` (the shortest route): -1 when none does.
  [[nodiscard]] int nextHop(int origin, int hub) const {
    if (flows(origin, hub)) return origin;
    for (int m = 0; m < topo_.hubs; ++m) {
      if (m != origin && m != hub && flows(origin, m) && flows(m, hub)) return m;
    }
    return -1;
  }

  // Every hub now. (A snapshot reads all 32768 channel slots: read them once per check.)
  std::vector<View> views() {
    std::vector<View> out(static_cast<size_t>(topo_.hubs));
    for (int h = 0; h < topo_.hubs; ++h) {
      HubSnapshot s = hubs_[h]->server->snapshot();
      for (auto& c : s.channels) out[h].channels[c.name] = std::move(c);
      for (auto& f : s.flows) out[h].flows[f.id] = std::move(f);
    }
    return out;
  }

  // The channels `hub` should show, each with the hub it comes from (itself for its own).
  [[nodiscard]] std::map<std::string, int> expected(int hub) const {
    std::map<std::string, int> out;
    for (int o = 0; o < topo_.hubs; ++o) {
      const int via = o == hub ? o : nextHop(o, hub);
      if (via < 0) continue;
      out[nameOn(hub, o, "guest.ping")] = via;
      for (int n = 0; n < kNames; ++n) {
        if (exists(o, n)) out[nameOn(hub, o, localName(n))] = via;
      }
      if (o == 1 && mirrored()) out[nameOn(hub, o, localName(kReplica))] = via;
    }
    return out;
  }

  // Whether every hub has the channels it should by name, read without a snapshot: polled while
  // the hubs are busy.
  [[nodiscard]] bool named() const {
    for (int h = 0; h < topo_.hubs; ++h) {
      const auto want = expected(h);
      if (hubs_[h]->server->channelCount() != want.size()) return false;
      for (const auto& [name, via] : want) {
        if (!hubs_[h]->caller->findChannel(name)) return false;
      }
    }
    return true;
  }

  // Whether every satellite among the subscribers has asked for its channel, where it is.
  [[nodiscard]] bool attached() const {
    for (const auto& [k, sub] : subs_) {
      if (sub->sat && expected(sub->hub).contains(sub->name) &&
          !sub->sat->isSubscribed(sub->name)) {
        return false;
      }
    }
    return true;
  }

  // Empty when every hub shows the channels the model says, each by the shortest route, and the
  // test's subscribers on each of them; else the first difference.
  std::string shown(const std::vector<View>& views) {
    for (int h = 0; h < topo_.hubs; ++h) {
      const View& v = views[h];
      const auto want = expected(h);
      for (const auto& [name, via] : want) {
        auto it = v.channels.find(name);
        if (it == v.channels.end()) return hubs_[h]->name + " lacks " + name;
        if (via != h && v.linkTo(it->second.owner_flow) != via) {
          return hubs_[h]->name + " has " + name + " from " + v.clientOf(it->second.owner_flow) +
                 ", not through " + kHubNames[via];
        }
      }
      for (const auto& [name, ch] : v.channels) {
        if (!want.contains(name)) return hubs_[h]->name + " has " + name + ", gone";
      }
      for (const auto& [k, sub] : subs_) {
        if (sub->hub != h || !want.contains(sub->name)) continue;
        const ChannelCounters& ch = v.channels.at(sub->name);
        if (std::none_of(ch.subscriber_flows.begin(), ch.subscriber_flows.end(),
                         [&](uint32_t f) { return v.clientOf(f) == sub->label; })) {
          return sub->label + " is not subscribed to " + sub->name + " on " + hubs_[h]->name;
        }
      }
    }
    return {};
  }

  // Calls guest.ping of every hub from every other one, and of its own hub from every satellite
  // of the test: what each connection carried before has been handled over there when the
  // answers are back (a connection's frames keep their order). Empty, or the calls not answered
  // in time.
  std::string barrier() {
    for (int h = 0; h < topo_.hubs; ++h) {
      for (int o = 0; o < topo_.hubs; ++o) {
        if (o == h || nextHop(o, h) < 0) continue;
        const std::string ping = nameOn(h, o, "guest.ping");
        auto id = hubs_[h]->caller->findChannel(ping);
        if (!id) continue;  // not shown (yet): shown() says so
        if (hubs_[h]->caller->request(*id, ++tag_, "ping", Variant())) {
          calls_[tag_] = hubs_[h]->name + " calling " + ping;
        }
      }
    }
    // And every satellite among the subscribers (those that left too) calls its own hub's.
    std::vector<Sub*> sats;
    for (const auto& [k, sub] : subs_) sats.push_back(sub.get());
    for (const auto& sub : left_) sats.push_back(sub.get());
    for (Sub* sub : sats) {
      if (!sub->sat || !sub->sat->isConnected()) continue;
      const uint32_t tag = ++tag_;
      calls_[tag] = sub->label + " calling guest.ping";
      auto sent = sub->sat->request("guest.ping", "ping", Variant(),
                                    [this, tag](const sat::Response&) { calls_.erase(tag); });
      if (!sent) calls_.erase(tag);
    }
    if (loop_.runUntil([&] { return calls_.empty(); }, kSettleNs)) return {};
    std::string why = "no answer to";
    for (const auto& [tag, call] : std::exchange(calls_, {})) why += " (" + call + ")";
    return why;
  }

  // Empty when every link subscribes over there to exactly the channels whose copy here has
  // subscribers, each publisher was told whether it has any, and the test's subscribers are on
  // what they asked for and nothing else; else the first difference.
  std::string demand(const std::vector<View>& views) {
    for (int far = 0; far < topo_.hubs; ++far) {
      for (int near = 0; near < topo_.hubs; ++near) {
        if (far == near) continue;
        // What the link of `near` subscribes to on `far`...
        std::set<std::string> held, behind;
        for (const auto& [name, ch] : views[far].channels) {
          for (uint32_t f : ch.subscriber_flows) {
            if (views[far].linkTo(f) == near) held.insert(name);
          }
        }
        // ...and the channels of `far` that have subscribers on `near`.
        const std::string prefix = std::string(kHubNames[far]) + "/";
        for (const auto& [name, ch] : views[near].channels) {
          if (views[near].linkTo(ch.owner_flow) != far || ch.subscriber_flows.empty()) continue;
          behind.insert(name.starts_with(prefix) ? name.substr(prefix.size()) : name);
        }
        if (held != behind) {
          std::string d = "the link of " + std::string(kHubNames[near]) + " subscribes on " +
                          kHubNames[far] + " to {";
          for (const auto& n : held) d += " " + n;
          d += " } but " + std::string(kHubNames[near]) + " has subscribers on {";
          for (const auto& n : behind) d += " " + n;
          return d + " }";
        }
      }
    }
    for (const auto& [key, o] : owners_) {
      const View& v = views[key.first];
      const std::string name = localName(key.second);
      if (!o->wrong.empty()) return hubs_[key.first]->name + ":" + name + ": " + o->wrong;
      const bool has = !v.channels.at(name).subscriber_flows.empty();
      if (has != o->told) {
        return "the publisher of " + hubs_[key.first]->name + ":" + name + " was told " +
               (o->told ? "it has subscribers" : "it has none") + ", it has " +
               std::to_string(v.channels.at(name).subscriber_flows.size());
      }
    }
    if (topo_.replica) {  // B's replica subscribes to its source while it has subscribers
      const View& v = views[1];
      const auto source = v.channels.find("A/guest.c0"), mirror = v.channels.find("hub.r0");
      const bool wanted = mirror != v.channels.end() && !mirror->second.subscriber_flows.empty();
      const bool held = source != v.channels.end() &&
                        std::any_of(source->second.subscriber_flows.begin(),
                                    source->second.subscriber_flows.end(), [&](uint32_t f) {
                                      return v.flows.at(f).kind == std::string("replica");
                                    });
      if (wanted != held) {
        return std::string("B's replica hub.r0 ") + (wanted ? "has" : "has no") +
               " subscribers, and " + (held ? "subscribes" : "does not subscribe") +
               " to A/guest.c0";
      }
    }
    for (int h = 0; h < topo_.hubs; ++h) {
      for (const auto& [name, ch] : views[h].channels) {
        std::multiset<std::string> there, wanted;
        for (uint32_t f : ch.subscriber_flows) {
          if (views[h].linkTo(f) < 0 && views[h].flows.at(f).kind != std::string("replica")) {
            there.insert(views[h].clientOf(f));
          }
        }
        for (const auto& [k, sub] : subs_) {
          if (sub->hub == h && sub->name == name) wanted.insert(sub->label);
        }
        if (there != wanted) {
          return hubs_[h]->name + ": " + name + " has " + std::to_string(there.size()) +
                 " subscribers of the test, " + std::to_string(wanted.size()) + " want it";
        }
      }
    }
    return {};
  }

  Topology topo_;
  test::TempDir dir_{"skrobot-link-demand"};
  Loop loop_;
  std::vector<std::unique_ptr<Hub>> hubs_;
  std::map<std::pair<int, int>, std::unique_ptr<test::UnixRelay>> relays_;  // i lists j
  bool up_[3][3] = {};
  std::map<std::pair<int, int>, std::unique_ptr<Owner>> owners_;  // (hub, name)
  std::map<int, std::unique_ptr<Sub>> subs_;
  std::vector<std::unique_ptr<Sub>> left_;  // unsubscribed from everything
  std::map<uint32_t, std::string> calls_;   // by tag
  uint32_t tag_ = 0;
};

// Runs `steps` on `topology`, checking after the start and after each step. Empty, or a report.
std::string run(const Topology& topology, const std::vector<Step>& steps, LogSink& logs) {
  logs.clear();
  Network net(topology);
  size_t done = 0;
  std::string why = net.settle();
  for (; why.empty() && done < steps.size(); ++done) {
    net.apply(steps[done]);
    why = net.settle();
  }
  if (why.empty()) return {};
  std::string out = text(topology) + "\nsteps:\n";
  for (size_t i = 0; i < steps.size(); ++i) {
    out += std::string(i + 1 == done ? "  > " : "    ") + text(steps[i]) + "\n";
  }
  if (done == 0) out += "  (before the first step)\n";
  out += "after that step: " + why + "\n" + net.dump() + "the last log lines:\n" + logs.last(40);
  return out;
}

// A random sequence: the hubs, their links, and up to 12 steps that can be taken in turn.
std::pair<Topology, std::vector<Step>> randomSequence(uint64_t seed) {
  std::mt19937_64 rng(seed);
  const auto pick = [&rng](int n) { return static_cast<int>(rng() % static_cast<uint64_t>(n)); };
  Topology t;
  t.hubs = 2 + pick(2);
  for (int i = 0; i < t.hubs; ++i) {
    for (int j = i + 1; j < t.hubs; ++j) {
      switch (pick(t.hubs == 2 ? 3 : 7)) {  // with three hubs a pair may be unlinked
        case 0:
        case 3:
          t.lists[i][j] = true;
          break;
        case 1:
        case 4:
          t.lists[j][i] = true;
          break;
        case 2:
        case 5:
          t.lists[i][j] = t.lists[j][i] = true;
          break;
        default:
          break;
      }
    }
  }
  t.replica = pick(2) == 1;
  // The model of what exists, to pick steps that can be taken.
  bool exists[3][kNames] = {}, up[3][3] = {};
  std::vector<int> subs;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) up[i][j] = t.lists[i][j] || t.lists[j][i];
  }
  std::vector<Step> steps;
  const int count = 1 + pick(12);
  int next_sub = 0;
  while (static_cast<int>(steps.size()) < count) {
    Step s;
    s.kind = static_cast<Step::Kind>(pick(7));
    s.hub = pick(t.hubs);
    s.other = pick(t.hubs);
    s.name = pick(kNames);
    s.abrupt = pick(2) == 1;
    s.socket = pick(2) == 1;
    switch (s.kind) {
      case Step::create:
        if (exists[s.hub][s.name]) continue;
        exists[s.hub][s.name] = true;
        break;
      case Step::remove:
        if (!exists[s.hub][s.name]) continue;
        exists[s.hub][s.name] = false;
        break;
      case Step::recreate:
        if (!exists[s.hub][s.name]) continue;
        break;
      case Step::join:
        if (t.replica && pick(3) == 0) s.name = kReplica, s.other = 1;
        s.sub = next_sub++;
        subs.push_back(s.sub);
        break;
      case Step::leave: {
        if (subs.empty()) continue;
        const size_t i = static_cast<size_t>(pick(static_cast<int>(subs.size())));
        s.sub = subs[i];
        subs.erase(subs.begin() + static_cast<std::ptrdiff_t>(i));
        break;
      }
      case Step::cut:
      case Step::restore: {
        const bool cut = s.kind == Step::cut;
        if (s.hub == s.other || !(t.lists[s.hub][s.other] || t.lists[s.other][s.hub]) ||
            up[s.hub][s.other] != cut) {
          continue;
        }
        up[s.hub][s.other] = up[s.other][s.hub] = !cut;
        break;
      }
    }
    steps.push_back(s);
  }
  return {t, steps};
}

uint64_t envNumber(const char* name, uint64_t fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::strtoull(v, nullptr, 10) : fallback;
}

Step make(Step::Kind kind, int hub, int other = 0, int name = 0) {
  Step s;
  s.kind = kind;
  s.hub = hub;
  s.other = other;
  s.name = name;
  return s;
}

Step leave(int sub, bool abrupt) {
  Step s;
  s.kind = Step::leave;
  s.sub = sub;
  s.abrupt = abrupt;
  return s;
}

Step join(int sub, int hub, int other, bool socket) {
  Step s = make(Step::join, hub, other);
  s.sub = sub;
  s.socket = socket;
  return s;
}

Step remove(int hub, bool abrupt) {
  Step s = make(Step::remove, hub);
  s.abrupt = abrupt;
  return s;
}

// Issue 39, item 1: B links to A; a satellite of B waits for A/guest.c0 (flowctl echo --wait),
// its publisher on A comes and goes, the satellite leaves while the channel is gone; when the
// publisher comes back nobody subscribes anywhere, and the link must not either (it did: the
// publisher was told "first subscriber" and its data crossed the link to nobody).
TEST(HubLinkDemand, AChannelRemovedWhileSubscribedComesBackWithNobodyBehindTheLink) {
  LogSink logs;
  Topology t;
  t.lists[1][0] = true;  // B -> A
  for (bool abrupt : {true, false}) {
    const std::string why = run(t,
                                {join(0, 1, 0, true), make(Step::create, 0), remove(0, abrupt),
                                 leave(0, abrupt), make(Step::create, 0)},
                                logs);
    EXPECT_TRUE(why.empty()) << why;
  }
}

// The same over one connection both ways, for a channel of either hub, and through a third hub.
TEST(HubLinkDemand, TheSameOverASharedConnectionAndThroughAThirdHub) {
  LogSink logs;
  Topology shared;
  shared.lists[0][1] = shared.lists[1][0] = true;
  for (int origin : {0, 1}) {
    const std::string why =
        run(shared,
            {join(0, 1 - origin, origin, true), make(Step::create, origin), remove(origin, false),
             leave(0, false), make(Step::create, origin)},
            logs);
    EXPECT_TRUE(why.empty()) << why;
  }
  Topology chain;
  chain.hubs = 3;
  chain.lists[2][1] = chain.lists[1][0] = true;  // C -> B -> A
  const std::string why = run(chain,
                              {join(0, 2, 0, true), make(Step::create, 0), remove(0, false),
                               leave(0, true), make(Step::create, 0)},
                              logs);
  EXPECT_TRUE(why.empty()) << why;
}

// An in-process subscriber (a module) waiting for a far channel subscribes the moment the link
// shows it, before the link has noted which far channel it is: the link must subscribe over
// there all the same (it did not: the publisher never heard of it and no data came).
TEST(HubLinkDemand, AModuleWaitingForAFarChannelMakesTheLinkSubscribeWhenItComes) {
  LogSink logs;
  Topology pair, shared, chain;
  pair.lists[1][0] = true;                         // B -> A
  shared.lists[0][1] = shared.lists[1][0] = true;  // A <-> B
  chain.hubs = 3;
  chain.lists[2][1] = chain.lists[1][0] = true;  // C -> B -> A
  for (const Topology& t : {pair, shared, chain}) {
    const int where = t.hubs - 1;
    const std::string why =
        run(t, {join(0, where, 0, false), make(Step::create, 0), leave(0, false)}, logs);
    EXPECT_TRUE(why.empty()) << why;
  }
}

// The same for a replica's channel (docs/hub-links.md, "Replicas"): a module waiting for it makes
// the replica subscribe to its source, and the link over there.
TEST(HubLinkDemand, AModuleWaitingForAReplicaMakesItSubscribeToItsSource) {
  LogSink logs;
  Topology t;
  t.lists[1][0] = true;  // B -> A
  t.replica = true;
  Step mirror = join(0, 1, 1, false);
  mirror.name = kReplica;
  const std::string why = run(t, {mirror, make(Step::create, 0), leave(0, true)}, logs);
  EXPECT_TRUE(why.empty()) << why;
}

// A replica is a channel of its own hub: the hubs its source came through see it too (they did
// not: it carried its source's route, which names them).
TEST(HubLinkDemand, AReplicaOfAFarChannelIsSeenByTheHubItMirrors) {
  LogSink logs;
  Topology shared;
  shared.lists[0][1] = shared.lists[1][0] = true;
  shared.replica = true;
  Step mirror = join(0, 0, 1, true);  // a satellite of A, on B/hub.r0
  mirror.name = kReplica;
  const std::string why = run(shared, {make(Step::create, 0), mirror}, logs);
  EXPECT_TRUE(why.empty()) << why;
}

// B mirrors A's channel, which comes to B directly and through C; B shares one connection with C
// (B dials it) and offers C the replica, which a satellite of C wants. When A-B is cut, the
// replica goes and comes back at once, through C: the new offer must be answered by the channel
// made for it, not by the withdrawn one C still lists (it was, and C's demand never reached B).
TEST(HubLinkDemand, AChannelOfferedAgainAtOnceKeepsTheDemandOverThere) {
  LogSink logs;
  Topology t;
  t.hubs = 3;
  t.lists[1][0] = t.lists[2][0] = true;  // B -> A, C -> A
  t.lists[1][2] = t.lists[2][1] = true;  // B <-> C
  t.replica = true;
  Step mirror = join(0, 2, 1, true);
  mirror.name = kReplica;
  const std::string why = run(
      t, {mirror, make(Step::create, 0), make(Step::cut, 0, 1), make(Step::restore, 0, 1)}, logs);
  EXPECT_TRUE(why.empty()) << why;
}

// A channel offered over one connection and made again here while the offer travels is offered
// again (it was not: the far hub showed it no more), whichever hub dialled.
TEST(HubLinkDemand, AChannelMadeAgainWhileItsOfferTravelsIsOfferedAgain) {
  LogSink logs;
  Topology shared;
  shared.lists[0][1] = shared.lists[1][0] = true;
  for (int origin : {0, 1}) {
    Step again = make(Step::recreate, origin);
    const std::string why =
        run(shared, {make(Step::create, origin), join(0, 1 - origin, origin, true), again}, logs);
    EXPECT_TRUE(why.empty()) << why;
  }
}

// Over one connection, a module of the hub that dialled answers a call from the other hub from
// inside the request (the barrier's guest.ping does): the answer must cross back (it was
// dropped, and the caller waited for its timeout).
TEST(HubLinkDemand, AModuleOfTheDiallerAnswersCallsOverTheSharedConnection) {
  LogSink logs;
  Topology shared;
  shared.lists[0][1] = shared.lists[1][0] = true;
  const std::string why = run(shared, {}, logs);
  EXPECT_TRUE(why.empty()) << why;
}

// Three hubs that list each other: when the connection between B and C is cut, each side takes
// the other's channels through A, and their subscribers follow. On the hub that was dialled,
// the connection's closing must make its other links offer again as a dropped link of its own
// does (it did not: B's channels never came back to C that way, or C's to B).
TEST(HubLinkDemand, WhenASharedConnectionIsCutItsChannelsComeThroughTheThirdHub) {
  LogSink logs;
  Topology triangle;
  triangle.hubs = 3;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) triangle.lists[i][j] = i != j;
  }
  const std::string why =
      run(triangle,
          {make(Step::create, 1), make(Step::create, 2), join(0, 2, 1, true), join(1, 1, 2, false),
           make(Step::cut, 1, 2), make(Step::restore, 1, 2)},
          logs);
  EXPECT_TRUE(why.empty()) << why;
}

TEST(HubLinkDemand, RandomSequencesKeepEveryLinksDemandEqualToTheDemandBehindIt) {
  LogSink logs;
  const bool seeded = std::getenv("LINK_DEMAND_SEED") != nullptr;
  const uint64_t first = envNumber("LINK_DEMAND_SEED", 1);
  const uint64_t count = envNumber("LINK_DEMAND_SEQUENCES", seeded ? 1 : 200);
  for (uint64_t seed = first; seed < first + count; ++seed) {
    const auto [topology, steps] = randomSequence(seed);
    const std::string why = run(topology, steps, logs);
    ASSERT_TRUE(why.empty()) << "LINK_DEMAND_SEED=" << seed << " fails:\n" << why;
  }
}

}  // namespace
}  // namespace skr::flow
