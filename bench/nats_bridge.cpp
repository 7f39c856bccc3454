// SPDX-License-Identifier: Apache-2.0
// The nats-bridge module (docs/fleet.md) against its baselines, in one run:
//   1. service round trip p50/p99 at 16 B, 1 KB and 64 KB over four paths: a raw NATS client pair
//      (libnats request/reply through nats-server), one hub (caller and server on the same hub),
//      a direct hub link, and hub -> NATS -> hub through the bridge; the target is a bridged p50
//      within raw NATS's p50 plus twice one hub's;
//   2. 1:1 streaming throughput at the same sizes over the same four paths, a few seconds each:
//      messages/s received, and what was lost on the way;
//   3. a fleet: N hub processes (20; --quick: 4), each with the bridge on a 3-node nats-server
//      cluster, each exporting 5 channels published at 30 Hz and importing one channel of every
//      other hub: the delivered rate against the expected one, a service round trip between two
//      hubs through the bridge under that load, the CPU of one hub process; then the same while
//      one NATS node is killed halfway (delivered rate, longest gap).
// Hubs are `skrobot` processes (the module is a plugin of the hub); satellites, publishers and
// raw NATS clients live in this process on threads of their own. Two cores run everything.
//
//   nats_bridge [--quick] [--hubs N]
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/spread.h>
#include <skrobot/satellite.h>

#include <json/json.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "bench_satellite.h"
#include "nats_server.h"

namespace {

using namespace skr;
using bench::Sat;
using bench::waitFor;
using flow::Variant;
using sat::test::freePort;
using sat::test::HubProcess;
using sat::test::NatsServer;
using sat::test::RawNats;
namespace fs = std::filesystem;
using std::chrono::milliseconds;

[[noreturn]] void fail(const std::string& why) {
  std::fprintf(stderr, "nats_bridge: %s\n", why.c_str());
  std::exit(1);
}

void sleepMs(double ms) {
  std::this_thread::sleep_for(std::chrono::microseconds(int64_t(ms * 1000)));
}

// --- processes ----------------------------------------------------------------------------------

// The pid of the first process whose argv `match` accepts, or 0.
pid_t pidWhere(const std::function<bool(const std::vector<std::string>&)>& match) {
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(e.path() / "cmdline", std::ios::binary);
    std::vector<std::string> args;
    for (std::string a; std::getline(in, a, '\0');) args.push_back(a);
    if (match(args)) return pid_t(std::stol(name));
  }
  return 0;
}

// utime + stime of `pid` in clock ticks (0 when it is gone).
uint64_t cpuTicks(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t paren = text.rfind(')');
  if (paren == std::string::npos) return 0;
  std::istringstream fields(text.substr(paren + 2));
  std::string f;
  uint64_t utime = 0, stime = 0;
  for (int i = 3; fields >> f && i <= 15; ++i) {  // field 3 is the state; 14 utime, 15 stime
    if (i == 14) utime = std::stoull(f);
    if (i == 15) stime = std::stoull(f);
  }
  return utime + stime;
}

// Time on a CPU of all the threads of `pid` now, in ns (/proc/<pid>/task/*/schedstat).
Nanos cpuNs(pid_t pid) {
  Nanos sum = 0;
  std::error_code ec;
  for (const auto& t : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
    std::ifstream in(t.path() / "schedstat");
    Nanos ns = 0;
    if (in >> ns) sum += ns;
  }
  return sum;
}

// Context switches of all the threads of `pid` so far, and how many threads it has now.
std::pair<uint64_t, int> contextSwitches(pid_t pid) {
  uint64_t sum = 0;
  int threads = 0;
  std::error_code ec;
  for (const auto& t : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
    ++threads;
    std::ifstream in(t.path() / "status");
    for (std::string line; std::getline(in, line);) {
      if (line.find("ctxt_switches:") != std::string::npos) {
        sum += std::stoull(line.substr(line.find(':') + 1));
      }
    }
  }
  return {sum, threads};
}

// The machine's busy and total jiffies (/proc/stat, all cores).
std::pair<uint64_t, uint64_t> machineTicks() {
  std::ifstream in("/proc/stat");
  std::string cpu;
  in >> cpu;
  uint64_t v[10] = {}, total = 0;
  for (auto& x : v) {
    in >> x;
    total += x;
  }
  return {total - v[3] - v[4], total};  // idle and iowait are not busy
}

// A hub process named `name` in <root>/<name>, with the development account.
class ProcHub {
 public:
  ProcHub(const fs::path& root, std::string name, const std::string& top_keys,
          const std::string& modules)
      : name_(std::move(name)), dir_(root / name_) {
    fs::create_directories(dir_);
    proc_ = std::make_unique<HubProcess>(SKROBOT_BIN, dir_, "", "",
                                         R"("hub_name": ")" + name_ + R"(", )" + top_keys, modules);
  }
  void start() {
    if (!proc_->start()) fail("hub " + name_ + " did not start:\n" + proc_->log());
    const std::vector<std::string> argv{SKROBOT_BIN, "--config", (dir_ / "hub.json").string()};
    pid_ = pidWhere([&](const std::vector<std::string>& a) { return a == argv; });
  }
  void waitLog(const std::string& text) const {
    if (!proc_->waitLog(text, 20000)) fail("hub " + name_ + ": no " + text + "\n" + proc_->log());
  }
  void stop() { proc_->stop(); }
  [[nodiscard]] sat::ConnectOptions connect(const std::string& client) const {
    sat::ConnectOptions o;
    o.address.kind = flow::Address::Kind::local;
    o.address.path = (dir_ / "hub.sock").string();
    o.client_name = client;
    o.timeout_ms = 30000;
    return o;
  }
  [[nodiscard]] std::string address() const { return "local:" + (dir_ / "hub.sock").string(); }
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] const fs::path& dir() const { return dir_; }
  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] std::string log() const { return proc_->log(); }

 private:
  std::string name_;
  fs::path dir_;
  std::unique_ptr<HubProcess> proc_;
  pid_t pid_ = 0;
};

// The bridge's entry for a hub's "modules" array: on `urls`, with more config members.
std::string bridgeModule(const std::vector<std::string>& urls, const std::string& members) {
  std::string servers;
  for (const auto& u : urls) servers += (servers.empty() ? "\"" : ", \"") + u + "\"";
  return R"([{"name": "nats-bridge", "config": {"servers": [)" + servers + "]" +
         (members.empty() ? "" : ", " + members) + "}}]";
}

Json::Value parseJson(const std::string& text) {
  Json::Value v;
  Json::CharReaderBuilder b;
  std::string errors;
  std::istringstream in(text);
  if (!Json::parseFromStream(b, in, &v, &errors)) return Json::Value();
  return v;
}

// A satellite that keeps the last status the hub's bridge published.
class StatusWatch {
 public:
  explicit StatusWatch(const ProcHub& hub) : sat_(hub, "status-watch") {
    sat_.on([this](sat::Satellite& s) {
      s.subscribed.connect(&s, [this](const sat::ChannelInfo& c) {
        if (c.name == "nats-bridge.status") id_ = c.id;
      });
      s.dataView.connect(&s, [this](uint16_t id, std::string_view payload) {
        if (id != id_) return;
        std::lock_guard lock(m_);
        last_.assign(payload);
        ++count_;
      });
    });
    // Connections take effect at the loop's next pulse: subscribing comes after.
    sat_.on([](sat::Satellite& s) { s.subscribe("nats-bridge.status"); });
    if (!waitFor([&] { return count() > 0; })) fail(hub.name() + ": no status from the bridge");
  }
  // The last status received.
  Json::Value last() {
    std::lock_guard lock(m_);
    return parseJson(last_);
  }
  [[nodiscard]] uint64_t count() {
    std::lock_guard lock(m_);
    return count_;
  }

 private:
  Sat sat_;
  std::atomic<int> id_{-1};
  std::mutex m_;
  std::string last_;
  uint64_t count_ = 0;
};

// Adds a service channel "echo" that answers each request with its value.
void serveEcho(Sat& s) {
  if (!s.on([](sat::Satellite& sat) {
        return bool(sat.addChannel({.name = "echo", .kind = flow::ChannelKind::service}));
      })) {
    fail("echo channel");
  }
  s.on([](sat::Satellite& sat) {
    sat.serviceRequest.connect(&sat,
                               [&sat](const sat::Request& r) { (void)sat.respond(r, r.value); });
  });
}

// --- service round trips ------------------------------------------------------------------------

Spread rawRoundTrips(RawNats& client, const std::string& subject, size_t bytes, int count) {
  const std::string payload(bytes, 'x');
  std::vector<double> us;
  for (int i = 0; i < count + count / 10; ++i) {
    const Nanos t0 = monotonicNs();
    auto r = client.request(subject, payload);
    if (!r || r->data != payload) fail("raw NATS request on " + subject);
    if (i >= count / 10) us.push_back(double(monotonicNs() - t0) / 1000.0);  // after a warm-up
  }
  return spreadOf(std::move(us));
}

// An echo replier as libnats advises for one (natsOptions_SetSendAsap): each reply is written
// at once. By default a publish waits in the client's buffer for its flusher thread, which
// waits 1 ms to batch more (nats.c conn.c, _flusher); a request is always sent at once.
class AsapEcho {
 public:
  AsapEcho(const std::string& url, const std::string& subject) {
    natsOptions* o = nullptr;
    natsOptions_Create(&o);
    natsOptions_SetURL(o, url.c_str());
    natsOptions_SetSendAsap(o, true);
    const bool up = natsConnection_Connect(&nc_, o) == NATS_OK;
    natsOptions_Destroy(o);
    if (!up ||
        natsConnection_Subscribe(
            &sub_, nc_, subject.c_str(),
            [](natsConnection* nc, natsSubscription*, natsMsg* m, void*) {
              if (natsMsg_GetReply(m) != nullptr) {
                natsConnection_Publish(nc, natsMsg_GetReply(m), natsMsg_GetData(m),
                                       natsMsg_GetDataLength(m));
              }
              natsMsg_Destroy(m);
            },
            nullptr) != NATS_OK ||
        natsConnection_Flush(nc_) != NATS_OK) {
      fail("raw NATS replier on " + subject);
    }
  }
  ~AsapEcho() {
    natsSubscription_Destroy(sub_);
    natsConnection_Destroy(nc_);
  }
  AsapEcho(const AsapEcho&) = delete;
  AsapEcho& operator=(const AsapEcho&) = delete;

 private:
  natsConnection* nc_ = nullptr;
  natsSubscription* sub_ = nullptr;
};

// A SyncClient on `at` calls `service` (by its id: one round trip per call, no CHAN_INFO).
Spread hubRoundTrips(const sat::ConnectOptions& at, const std::string& service, size_t bytes,
                     int count) {
  auto c = sat::SyncClient::connect(at);
  if (!c) fail("caller: " + c.error().message);
  std::optional<uint16_t> id;
  waitFor([&] {
    auto info = c->channel(service);
    if (info) id = info->id;
    return id.has_value();
  });
  if (!id) fail("no channel " + service);
  const Variant payload(std::string(bytes, 'x'));
  std::vector<double> us;
  for (int i = 0; i < count + count / 10; ++i) {
    const Nanos t0 = monotonicNs();
    auto r = c->call(*id, "echo", payload, 5000);
    if (!r) fail("call " + service + ": " + r.error().message);
    if (!(*r == payload)) fail("call " + service + " answered " + flow::variantToJsonText(*r));
    if (i >= count / 10) us.push_back(double(monotonicNs() - t0) / 1000.0);
  }
  return spreadOf(std::move(us));
}

// --- streaming ----------------------------------------------------------------------------------

struct Stream {
  double per_second = 0;  // received, from the first publish to the last receipt
  uint64_t sent = 0, received = 0;
  // What the receiver was told was dropped: EV_DROPPED, or the NATS client's slow-consumer drops.
  uint64_t dropped = 0;
};

// Waits until `got` reaches `sent` or stays still for 1 s.
void waitTail(const std::atomic<uint64_t>& got, uint64_t sent) {
  uint64_t seen = got;
  Nanos since = monotonicNs();
  while (got < sent && monotonicNs() - since < kNsPerSec) {
    sleepMs(10);
    if (got != seen) {
      seen = got;
      since = monotonicNs();
    }
  }
}

// `pub` publishes on its channel `pub_chan` as fast as its queue lets it for `secs`; `sub`
// counts what arrives on `sub_name`.
Stream hubStream(Sat& pub, const std::string& pub_chan, Sat& sub, const std::string& sub_name,
                 size_t bytes, double secs) {
  std::atomic<int> target{-1};
  std::atomic<uint64_t> got{0};
  std::atomic<Nanos> last{0};
  skr::Connection conn;
  sub.on([&](sat::Satellite& s) {
    conn = s.dataView.connect(&s, [&](uint16_t id, std::string_view) {
      if (id != target) return;
      ++got;
      last = monotonicNs();
    });
  });
  sub.on([&](sat::Satellite& s) { s.subscribe(sub_name); });
  if (!waitFor([&] { return sub.on([&](sat::Satellite& s) { return s.isSubscribed(sub_name); }); }))
    fail("cannot subscribe to " + sub_name);
  target = sub.on([&](sat::Satellite& s) { return int(s.channelId(sub_name).value_or(0)); });
  if (!waitFor(
          [&] { return pub.on([&](sat::Satellite& s) { return s.hasSubscribers(pub_chan); }); }))
    fail("no subscriber for " + pub_chan);
  const std::string payload(bytes, 'p');
  // Until one gets through: an import is subscribed on NATS by the bridge's thread, later.
  if (!waitFor(
          [&] {
            (void)pub.on([&](sat::Satellite& s) { return bool(s.publish(pub_chan, payload)); });
            sleepMs(20);
            return got > 0;
          },
          15000)) {
    fail("nothing arrives on " + sub_name);
  }
  sleepMs(300);
  const uint64_t dropped0 = sub.on([](sat::Satellite& s) { return s.stats().data_dropped; });
  got = 0;
  uint64_t sent = 0;
  const Nanos first = monotonicNs();
  const Nanos end = first + Nanos(secs * 1e9);
  while (monotonicNs() < end) {
    pub.on([&](sat::Satellite& s) {
      for (int n = 0; n < 20000 && s.queuedBytes() < (16u << 20); ++n) {
        if (!s.publish(pub_chan, payload)) break;
        ++sent;
      }
    });
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  waitTail(got, sent);
  Stream r;
  r.sent = sent;
  r.received = got;
  r.dropped = sub.on([](sat::Satellite& s) { return s.stats().data_dropped; }) - dropped0;
  r.per_second = last > first ? double(r.received) / (double(last - first) / 1e9) : 0;
  sub.on([&](sat::Satellite& s) {
    s.unsubscribe(sub_name);
    conn.disconnect();
  });
  sleepMs(200);
  return r;
}

// The same between two raw NATS connections.
Stream rawStream(const std::string& url, size_t bytes, double secs) {
  RawNats pub(url), sub(url);
  if (!pub.ok() || !sub.ok()) fail("raw NATS connect");
  struct Counter {
    std::atomic<uint64_t> got{0};
    std::atomic<Nanos> last{0};
  } c;
  natsSubscription* s = nullptr;
  if (natsConnection_Subscribe(
          &s, sub.nc(), "bench.load",
          [](natsConnection*, natsSubscription*, natsMsg* m, void* p) {
            auto* c = static_cast<Counter*>(p);
            ++c->got;
            c->last = monotonicNs();
            natsMsg_Destroy(m);
          },
          &c) != NATS_OK) {
    fail("raw NATS subscribe");
  }
  natsConnection_Flush(sub.nc());
  const std::string payload(bytes, 'p');
  auto send = [&] {
    return natsConnection_Publish(pub.nc(), "bench.load", payload.data(), int(payload.size())) ==
           NATS_OK;
  };
  if (!waitFor([&] {
        send();
        natsConnection_Flush(pub.nc());
        return c.got > 0;
      })) {
    fail("raw NATS: nothing arrives");
  }
  sleepMs(300);
  c.got = 0;
  uint64_t sent = 0;
  const Nanos first = monotonicNs();
  const Nanos end = first + Nanos(secs * 1e9);
  while (monotonicNs() < end) {
    for (int n = 0; n < 100; ++n) sent += send() ? 1 : 0;
  }
  natsConnection_FlushTimeout(pub.nc(), 10000);
  waitTail(c.got, sent);
  Stream r;
  r.sent = sent;
  r.received = c.got;
  int64_t dropped = 0;
  natsSubscription_GetDropped(s, &dropped);
  r.dropped = uint64_t(dropped);
  r.per_second = c.last > first ? double(r.received) / (double(c.last - first) / 1e9) : 0;
  natsSubscription_Unsubscribe(s);
  natsSubscription_Destroy(s);
  return r;
}

// --- sections 1 and 2 ---------------------------------------------------------------------------

void pointToPoint(const fs::path& dir, bool quick) {
  NatsServer nats(dir, "solo", false);
  if (!nats.start()) fail("nats-server:\n" + nats.log());
  // h2 links to h1 directly, and both bridge to the same nats-server: h1 exports its echo
  // service and a stream that h2 imports. The baselines' channels are not exported.
  ProcHub h1(dir, "h1", "",
             bridgeModule({nats.url()}, R"("export": ["guest.echo", "guest.bload"])"));
  const fs::path pass = dir / "h1.pass";
  std::ofstream(pass) << "password\n";
  ::chmod(pass.c_str(), 0600);
  ProcHub h2(dir, "h2",
             R"("links": [{"name": "h1", "address": ")" + h1.address() +
                 R"(", "user": "guest", "password_file": ")" + pass.string() + R"("}], )",
             bridgeModule({nats.url()}, R"("import": [
                 {"subject": "skrobot.h1.guest.echo", "as": "h1-echo", "service": true},
                 {"subject": "skrobot.h1.guest.bload", "as": "h1-load"}])"));
  h1.start();
  h2.start();
  h1.waitLog("NATS-CONNECTED");
  h2.waitLog("NATS-CONNECTED");

  Sat owner(h1, "owner");
  serveEcho(owner);
  if (!owner.on([](sat::Satellite& s) {
        return bool(s.addChannel({.name = "load"})) && bool(s.addChannel({.name = "bload"}));
      })) {
    fail("owner channels");
  }
  Sat sub1(h1, "sub1");
  Sat sub2(h2, "sub2");
  if (!waitFor(
          [&] { return bench::sees(sub2, "h1/guest.echo") && bench::sees(sub2, "h1/guest.load"); }))
    fail("the link did not bring h1's channels");
  if (!waitFor([&] { return bench::sees(sub2, "nats-bridge.h1-echo"); }))
    fail("no import channel on h2");
  StatusWatch status1(h1), status2(h2);

  RawNats raw_server(nats.url()), raw_client(nats.url());
  if (!raw_server.ok() || !raw_client.ok()) fail("raw NATS connect");
  if (!raw_server.serve("bench.echo", [](const std::string& in) { return in; }))
    fail("raw NATS serve");
  AsapEcho asap_server(nats.url(), "bench.echo.asap");

  const char* names[] = {"raw NATS", "one hub", "hub link", "bridge", "NATS asap"};
  const size_t sizes[] = {16, 1024, 65536};
  const int calls = quick ? 200 : 1000;
  std::printf("1. Service round trip (us), %d calls each after %d warm-up calls\n", calls,
              calls / 10);
  std::printf(
      "   raw NATS: libnats request/reply through nats-server (replier with default options);\n"
      "   one hub: both satellites on h1; hub link: caller on h2, h2 -> h1 link;\n"
      "   bridge: caller on h2 calls nats-bridge.h1-echo -> NATS -> h1's guest.echo;\n"
      "   NATS asap: raw NATS with a replier that sends at once (natsOptions_SetSendAsap)\n");
  std::printf("   hub CPU: the time both hub processes spent on a CPU, per call (us)\n");
  std::printf("%-7s %-9s %9s %9s %9s %8s %8s %8s\n", "size", "path", "p50", "p99", "max", "x hub",
              "x NATS", "hub CPU");
  std::map<size_t, std::array<Spread, 5>> rtt;
  for (size_t bytes : sizes) {
    auto& row = rtt[bytes];
    double hub_cpu[5] = {};
    // Runs `calls` calls (and the warm-up) and notes the hubs' CPU time per call.
    auto timed = [&](int p, const std::function<Spread()>& run) {
      const Nanos c0 = cpuNs(h1.pid()) + cpuNs(h2.pid());
      row[size_t(p)] = run();
      hub_cpu[p] = double(cpuNs(h1.pid()) + cpuNs(h2.pid()) - c0) / 1e3 / (calls + calls / 10);
    };
    timed(0, [&] { return rawRoundTrips(raw_client, "bench.echo", bytes, calls); });
    timed(1, [&] { return hubRoundTrips(h1.connect("caller"), "guest.echo", bytes, calls); });
    timed(2, [&] { return hubRoundTrips(h2.connect("caller"), "h1/guest.echo", bytes, calls); });
    timed(3,
          [&] { return hubRoundTrips(h2.connect("caller"), "nats-bridge.h1-echo", bytes, calls); });
    timed(4, [&] { return rawRoundTrips(raw_client, "bench.echo.asap", bytes, calls); });
    for (int p = 0; p < 5; ++p) {
      std::printf("%-7zu %-9s %9.1f %9.1f %9.1f %8.2f %8.2f %8.1f\n", bytes, names[p], row[p].p50,
                  row[p].p99, row[p].max, row[p].p50 / row[1].p50, row[p].p50 / row[0].p50,
                  hub_cpu[p]);
    }
  }
  std::printf("Target: bridged p50 <= raw NATS p50 + 2 x one hub p50 (and against NATS asap)\n");
  for (size_t bytes : sizes) {
    const auto& row = rtt[bytes];
    const double bound = row[0].p50 + 2 * row[1].p50;
    const double floor = row[4].p50 + 2 * row[1].p50;
    std::printf(
        "  %-6zu bridged %8.1f us vs %7.1f + 2 x %7.1f = %8.1f us: %s   (asap: %8.1f us: "
        "%s)\n",
        bytes, row[3].p50, row[0].p50, row[1].p50, bound, row[3].p50 <= bound ? "PASS" : "MISS",
        floor, row[3].p50 <= floor ? "PASS" : "MISS");
  }

  const double secs = quick ? 0.5 : 2.0;
  std::printf(
      "\n2. 1:1 streaming for %.1f s each, as fast as the publisher's queue takes it: "
      "received messages/s; lost = sent - received; ratio against one hub\n",
      secs);
  std::printf("%-7s %-9s %11s %9s %10s %10s %10s %7s\n", "size", "path", "msgs/s", "MB/s", "sent",
              "received", "lost", "ratio");
  std::vector<std::string> notes;
  for (size_t bytes : sizes) {
    Stream row[4];
    row[0] = rawStream(nats.url(), bytes, secs);
    row[1] = hubStream(owner, "load", sub1, "guest.load", bytes, secs);
    row[2] = hubStream(owner, "load", sub2, "h1/guest.load", bytes, secs);
    // The bridges' counters only move in the bridged run: a status before it, one after.
    const Json::Value s1 = status1.last(), s2 = status2.last();
    row[3] = hubStream(owner, "bload", sub2, "nats-bridge.h1-load", bytes, secs);
    const uint64_t c1 = status1.count(), c2 = status2.count();
    waitFor([&] { return status1.count() > c1 && status2.count() > c2; }, 3000);
    const Json::Value e1 = status1.last(), e2 = status2.last();
    for (int p = 0; p < 4; ++p) {
      const Stream& s = row[p];
      std::printf("%-7zu %-9s %11.0f %9.1f %10llu %10llu %10llu %7.2f\n", bytes, names[p],
                  s.per_second, s.per_second * double(bytes) / 1e6, (unsigned long long)s.sent,
                  (unsigned long long)s.received, (unsigned long long)(s.sent - s.received),
                  s.per_second / row[1].per_second);
    }
    auto delta = [](const Json::Value& a, const Json::Value& b, const char* k) {
      return (unsigned long long)(b[k].asUInt64() - a[k].asUInt64());
    };
    char line[400];
    std::snprintf(line, sizeof line,
                  "  %6zu B: raw NATS subscriber's slow-consumer drops %llu; hub drops for sub "
                  "(EV_DROPPED) one hub %llu, link %llu, bridge %llu; bridge h1 out_msgs +%llu "
                  "out_dropped +%llu; h2 in_msgs +%llu in_dropped +%llu",
                  bytes, (unsigned long long)row[0].dropped, (unsigned long long)row[1].dropped,
                  (unsigned long long)row[2].dropped, (unsigned long long)row[3].dropped,
                  delta(s1, e1, "out_msgs"), delta(s1, e1, "out_dropped"), delta(s2, e2, "in_msgs"),
                  delta(s2, e2, "in_dropped"));
    notes.emplace_back(line);
  }
  std::printf("Where the losses were:\n");
  for (const auto& n : notes) std::printf("%s\n", n.c_str());
  std::fflush(stdout);
}

// --- section 3: the fleet -----------------------------------------------------------------------

constexpr int kChannels = 5;
constexpr double kRateHz = 30;
constexpr size_t kFleetPayload = 256;

struct MsgHead {
  uint64_t seq;
  Nanos sent;
};

// One import stream as its subscriber sees it within a window.
struct StreamStat {
  uint64_t count = 0;
  uint64_t lost = 0;  // gaps in the sequence numbers
  uint64_t last_seq = 0;
  bool any = false;  // a message arrived, ever
  Nanos last = 0;    // the last receipt, or the window's start
  Nanos max_gap = 0;
};

struct NodeWindow {
  Nanos start = 0, end = 0;
  std::vector<StreamStat> streams;
  std::vector<double> latency_us;
  uint64_t published = 0, publish_failed = 0;
  std::string status;
};

// The satellite of fleet hub f<index>: it owns the hub's 5 channels (published at 30 Hz by
// publishTick()) and subscribes to the hub's imports. Its state is its loop thread's.
class FleetNode {
 public:
  FleetNode(const ProcHub& hub, int index, const std::vector<std::string>& imports, bool echo)
      : sat(hub, "fleet-" + hub.name()), index_(index), streams_(imports.size()) {
    payload_.assign(kFleetPayload, 'f');
    if (echo) serveEcho(sat);
    if (!sat.on([](sat::Satellite& s) {
          for (int k = 0; k < kChannels; ++k) {
            if (!s.addChannel({.name = "c" + std::to_string(k)})) return false;
          }
          return true;
        })) {
      fail("fleet channels");
    }
    for (size_t i = 0; i < imports.size(); ++i) index_of_[imports[i]] = int(i);
    names_ = imports;
    sat.on([this](sat::Satellite& s) {
      s.subscribed.connect(&s, [this](const sat::ChannelInfo& c) {
        if (c.name == "nats-bridge.status") status_id_ = c.id;
        if (auto it = index_of_.find(c.name); it != index_of_.end()) stream_of_[c.id] = it->second;
      });
      s.dataView.connect(&s, [this](uint16_t id, std::string_view p) { onData(id, p); });
    });
    sat.on([&imports](sat::Satellite& s) {  // after the connections took effect
      for (const auto& name : imports) s.subscribe(name);
      s.subscribe("nats-bridge.status");
    });
  }
  // Loop thread: one message on each channel.
  void publishTick() {
    sat.on([this](sat::Satellite& s) {
      for (int k = 0; k < kChannels; ++k) {
        const MsgHead h{seq_[k]++, monotonicNs()};
        std::memcpy(payload_.data(), &h, sizeof h);
        if (s.publish("c" + std::to_string(k), payload_)) {
          ++published_;
        } else {
          ++publish_failed_;
        }
      }
    });
  }
  void reset() {
    sat.on([this](sat::Satellite&) {
      const Nanos now = monotonicNs();
      start_ = now;
      for (auto& st : streams_) {
        st.count = st.lost = 0;
        st.max_gap = 0;
        st.last = now;
      }
      latency_us_.clear();
      published_ = publish_failed_ = 0;
    });
  }
  NodeWindow snapshot() {
    NodeWindow w;
    sat.on([&](sat::Satellite&) {
      w.start = start_;
      w.end = monotonicNs();
      w.streams = streams_;
      for (auto& st : w.streams) st.max_gap = std::max(st.max_gap, w.end - st.last);
      w.latency_us = latency_us_;
      w.published = published_;
      w.publish_failed = publish_failed_;
      w.status = status_;
    });
    return w;
  }
  // Imports that have delivered nothing since the last reset().
  int silentStreams() {
    int n = 0;
    sat.on([&](sat::Satellite&) {
      for (const auto& st : streams_) n += st.count == 0 ? 1 : 0;
    });
    return n;
  }
  Json::Value status() {
    std::string text;
    sat.on([&](sat::Satellite&) { text = status_; });
    return parseJson(text);
  }
  [[nodiscard]] const std::string& streamName(size_t i) const { return names_[i]; }
  [[nodiscard]] int index() const { return index_; }

  Sat sat;

 private:
  void onData(uint16_t id, std::string_view p) {
    if (id == status_id_) {
      status_.assign(p);
      return;
    }
    auto it = stream_of_.find(id);
    if (it == stream_of_.end() || p.size() < sizeof(MsgHead)) return;
    StreamStat& st = streams_[size_t(it->second)];
    MsgHead h;
    std::memcpy(&h, p.data(), sizeof h);
    const Nanos now = monotonicNs();
    if (st.any && h.seq > st.last_seq + 1) st.lost += h.seq - st.last_seq - 1;
    st.any = true;
    st.last_seq = std::max(st.last_seq, h.seq);
    st.max_gap = std::max(st.max_gap, now - st.last);
    st.last = now;
    ++st.count;
    latency_us_.push_back(double(now - h.sent) / 1000.0);
  }

  int index_;
  std::string payload_;
  uint64_t seq_[kChannels] = {};
  uint64_t published_ = 0, publish_failed_ = 0;
  std::map<std::string, int> index_of_;
  std::vector<std::string> names_;
  std::unordered_map<uint16_t, int> stream_of_;
  int status_id_ = -1;
  std::string status_;
  std::vector<StreamStat> streams_;
  std::vector<double> latency_us_;
  Nanos start_ = 0;
};

struct Call {
  Nanos at;
  double us;
  bool ok;
};

// CPU over a window: processes and the machine.
class CpuMeter {
 public:
  explicit CpuMeter(std::vector<pid_t> pids) : pids_(std::move(pids)) {
    for (pid_t p : pids_) start_.push_back(cpuTicks(p));
    machine_ = machineTicks();
    t0_ = monotonicNs();
  }
  // % of one core per process (-1: gone meanwhile), and the machine's busy share of all its
  // cores (%).
  std::pair<std::vector<double>, double> stop() const {
    const double secs = double(monotonicNs() - t0_) / 1e9;
    const double hz = double(::sysconf(_SC_CLK_TCK));
    std::vector<double> pct;
    for (size_t i = 0; i < pids_.size(); ++i) {
      const uint64_t end = cpuTicks(pids_[i]);
      pct.push_back(end < start_[i] || end == 0 ? -1 : double(end - start_[i]) / hz / secs * 100);
    }
    const auto m = machineTicks();
    const double busy = double(m.first - machine_.first) /
                        double(std::max<uint64_t>(1, m.second - machine_.second)) * 100;
    return {pct, busy};
  }

 private:
  std::vector<pid_t> pids_;
  std::vector<uint64_t> start_;
  std::pair<uint64_t, uint64_t> machine_;
  Nanos t0_;
};

void fleet(const fs::path& dir, bool quick, int hubs) {
  const double window_s = quick ? 3 : 15;
  // The cluster: three nodes routed to each other.
  std::vector<std::unique_ptr<NatsServer>> nodes;
  std::vector<int> cluster_ports{freePort(), freePort(), freePort()};
  for (int i = 0; i < 3; ++i) {
    nodes.push_back(std::make_unique<NatsServer>(dir, "n" + std::to_string(i), false));
    std::vector<int> routes;
    for (int j = 0; j < 3; ++j) {
      if (j != i) routes.push_back(cluster_ports[size_t(j)]);
    }
    nodes.back()->cluster(cluster_ports[size_t(i)], routes);
  }
  for (auto& n : nodes) {
    if (!n->start()) fail("nats-server cluster node:\n" + n->log());
  }
  sleepMs(500);  // routes formed
  std::vector<std::string> urls;
  for (auto& n : nodes) urls.push_back(n->url());

  // Hub f<i> imports channel c<i % 5> of every other hub; f0 also imports f1's echo service.
  auto hubName = [](int i) { return "f" + std::to_string(i); };
  std::vector<std::unique_ptr<ProcHub>> procs;
  std::vector<std::vector<std::string>> imports(static_cast<size_t>(hubs));
  const Nanos boot0 = monotonicNs();
  for (int i = 0; i < hubs; ++i) {
    std::string list;
    const std::string k = "c" + std::to_string(i % kChannels);
    for (int j = 0; j < hubs; ++j) {
      if (j == i) continue;
      const std::string as = hubName(j) + "-" + k;
      list += std::string(list.empty() ? "" : ", ") + R"({"subject": "skrobot.)" + hubName(j) +
              ".guest." + k + R"(", "as": ")" + as + R"("})";
      imports[size_t(i)].push_back("nats-bridge." + as);
    }
    if (i == 0)
      list += R"(, {"subject": "skrobot.f1.guest.echo", "as": "f1-echo", "service": true})";
    // Each hub lists the three nodes, in an order of its own (the client shuffles it too).
    std::vector<std::string> order{urls[size_t(i % 3)], urls[size_t((i + 1) % 3)],
                                   urls[size_t((i + 2) % 3)]};
    procs.push_back(std::make_unique<ProcHub>(
        dir / "fleet", hubName(i), "",
        bridgeModule(order, R"("export": ["guest.**"], "import": [)" + list + "]")));
  }
  for (auto& p : procs) p->start();
  for (auto& p : procs) p->waitLog("NATS-CONNECTED");
  const double boot_s = double(monotonicNs() - boot0) / 1e9;

  std::vector<std::unique_ptr<FleetNode>> fleet_nodes;
  for (int i = 0; i < hubs; ++i) {
    fleet_nodes.push_back(
        std::make_unique<FleetNode>(*procs[size_t(i)], i, imports[size_t(i)], i == 1));
  }
  // The publishers: every node's 5 channels each 1/30 s, on absolute deadlines.
  std::atomic<bool> pacing{true};
  std::atomic<uint64_t> ticks{0};
  std::thread pacer([&] {
    const Nanos t0 = monotonicNs();
    for (uint64_t tick = 0; pacing; ++tick) {
      std::this_thread::sleep_until(std::chrono::steady_clock::time_point(
          std::chrono::nanoseconds(t0 + Nanos(double(tick) * 1e9 / kRateHz))));
      for (auto& n : fleet_nodes) n->sat.loop().post([p = n.get()] { p->publishTick(); });
      ++ticks;
    }
  });
  // Every import flowing (each is subscribed on NATS by its bridge once the satellite came).
  for (auto& n : fleet_nodes) n->reset();
  const Nanos flow0 = monotonicNs();
  waitFor(
      [&] {
        for (auto& n : fleet_nodes) {
          if (n->silentStreams() > 0) return false;
        }
        return true;
      },
      30000);
  int silent = 0;
  for (auto& n : fleet_nodes) silent += n->silentStreams();
  const double flow_s = double(monotonicNs() - flow0) / 1e9;

  // The round trip f0 -> f1 through the bridge, every 20 ms, all along.
  std::mutex calls_m;
  std::vector<Call> calls;
  std::atomic<bool> calling{true};
  std::thread caller([&] {
    auto c = sat::SyncClient::connect(procs[0]->connect("caller"));
    if (!c) fail("fleet caller: " + c.error().message);
    std::optional<uint16_t> id;
    waitFor([&] {
      if (auto info = c->channel("nats-bridge.f1-echo")) id = info->id;
      return id.has_value();
    });
    if (!id) fail("no nats-bridge.f1-echo on f0");
    const Variant payload(std::string(16, 'x'));
    while (calling) {
      const Nanos t0 = monotonicNs();
      auto r = c->call(*id, "echo", payload, 5000);
      const Nanos t1 = monotonicNs();
      {
        std::lock_guard lock(calls_m);
        calls.push_back({t0, double(t1 - t0) / 1000.0, r && *r == payload});
      }
      sleepMs(20);
    }
  });
  sleepMs(quick ? 500 : 2000);  // settled

  const int probe = hubs > 2 ? 2 : 0;  // a hub with nothing but the common load
  std::vector<pid_t> pids;
  for (auto& p : procs) pids.push_back(p->pid());
  for (auto& n : nodes) {
    const std::string port = std::to_string(n->port());
    pids.push_back(pidWhere([&](const std::vector<std::string>& a) {
      return !a.empty() && a[0] == NATS_SERVER_BIN &&
             std::find(a.begin(), a.end(), port) != a.end();
    }));
  }

  struct Figures {
    double secs = 0;
    double delivered = 0, expected = 0;
    uint64_t lost = 0;
    double published_hz = 0;
    uint64_t publish_failed = 0;
    Spread latency_us;
    Nanos worst_gap = 0;
    std::string worst_stream;
    double median_gap_ms = 0;
    int streams_gap_500ms = 0;
    Spread rtt;
    size_t calls = 0, call_errors = 0;
    std::vector<double> cpu;
    double machine = 0;
    uint64_t out_dropped = 0, in_dropped = 0;
    double switches_per_s = 0;  // the probe hub's context switches
    int threads = 0;            // and its threads
  };
  auto measure = [&](const std::function<void()>& midway) {
    Figures r;
    CpuMeter cpu(pids);
    const uint64_t switches0 = contextSwitches(procs[size_t(probe)]->pid()).first;
    for (auto& n : fleet_nodes) n->reset();
    const Nanos t0 = monotonicNs();
    sleepMs(window_s * 500);
    midway();
    sleepMs(window_s * 500);
    const Nanos t1 = monotonicNs();
    std::tie(r.cpu, r.machine) = cpu.stop();
    r.secs = double(t1 - t0) / 1e9;
    const auto [switches1, threads] = contextSwitches(procs[size_t(probe)]->pid());
    r.switches_per_s = double(switches1 - switches0) / r.secs;
    r.threads = threads;
    std::vector<double> lat;
    std::vector<double> gaps_ms;
    uint64_t published = 0;
    for (auto& n : fleet_nodes) {
      NodeWindow w = n->snapshot();
      const double secs = double(w.end - w.start) / 1e9;
      r.expected += double(w.streams.size()) * kRateHz * secs;
      published += w.published;
      r.publish_failed += w.publish_failed;
      for (size_t s = 0; s < w.streams.size(); ++s) {
        const StreamStat& st = w.streams[s];
        r.delivered += double(st.count);
        r.lost += st.lost;
        gaps_ms.push_back(double(st.max_gap) / 1e6);
        if (st.max_gap > r.worst_gap) {
          r.worst_gap = st.max_gap;
          r.worst_stream = n->streamName(s) + " on f" + std::to_string(n->index());
        }
        r.streams_gap_500ms += st.max_gap > 500 * kNsPerMs ? 1 : 0;
      }
      lat.insert(lat.end(), w.latency_us.begin(), w.latency_us.end());
      const Json::Value st = parseJson(w.status);
      r.out_dropped += st["out_dropped"].asUInt64();
      r.in_dropped += st["in_dropped"].asUInt64();
    }
    r.published_hz = double(published) / (kChannels * double(hubs)) / r.secs;
    r.latency_us = spreadOf(std::move(lat));
    std::sort(gaps_ms.begin(), gaps_ms.end());
    r.median_gap_ms = gaps_ms.empty() ? 0 : gaps_ms[gaps_ms.size() / 2];
    std::vector<double> us;
    {
      std::lock_guard lock(calls_m);
      for (const Call& c : calls) {
        if (c.at < t0 || c.at > t1) continue;
        ++r.calls;
        if (!c.ok) ++r.call_errors;
        us.push_back(c.us);
      }
    }
    r.rtt = spreadOf(std::move(us));
    return r;
  };
  auto print = [&](const Figures& r) {
    const size_t streams = size_t(hubs) * size_t(hubs - 1);
    std::printf(
        "   delivered %.0f msgs/s of %.0f expected (%zu streams x %.0f Hz): %.2f%%; "
        "lost (sequence gaps) %llu\n",
        r.delivered / r.secs, r.expected / r.secs, streams, kRateHz,
        r.expected > 0 ? r.delivered / r.expected * 100 : 0, (unsigned long long)r.lost);
    std::printf(
        "   published %.1f Hz per channel (%llu publishes refused); publish -> receipt "
        "latency p50 %.0f us, p99 %.0f us, max %.0f us\n",
        r.published_hz, (unsigned long long)r.publish_failed, r.latency_us.p50, r.latency_us.p99,
        r.latency_us.max);
    std::printf(
        "   longest gap in a stream %.0f ms (%s); median stream's longest gap %.0f ms; "
        "streams with a gap > 500 ms: %d\n",
        double(r.worst_gap) / 1e6, r.worst_stream.c_str(), r.median_gap_ms, r.streams_gap_500ms);
    std::printf(
        "   round trip f0 -> NATS -> f1 (16 B, every 20 ms): p50 %.0f us, p99 %.0f us, "
        "max %.0f us; %zu calls, %zu failed\n",
        r.rtt.p50, r.rtt.p99, r.rtt.max, r.calls, r.call_errors);
    double sum = 0, top = 0;
    for (int i = 0; i < hubs; ++i) {
      sum += r.cpu[size_t(i)];
      top = std::max(top, r.cpu[size_t(i)]);
    }
    std::string servers;
    for (size_t k = 0; k < 3; ++k) {
      const double v = r.cpu[size_t(hubs) + k];
      char one[32];
      std::snprintf(one, sizeof one, v < 0 ? " n%zu killed" : " n%zu %.1f%%", k, v);
      servers += one;
    }
    std::printf(
        "   CPU (%% of one core): hub f%d %.1f%%; hubs mean %.1f%%, max %.1f%%, all %d "
        "together %.0f%%; nats-server%s; machine %.0f%% of %ld cores busy\n",
        probe, r.cpu[size_t(probe)], sum / hubs, top, hubs, sum, servers.c_str(), r.machine,
        ::sysconf(_SC_NPROCESSORS_ONLN));
    // The probe hub's channels: each of its 5 goes out once, each of its imports comes in.
    const double messages = kRateHz * (kChannels + (hubs - 1));
    std::printf(
        "   hub f%d: %d threads, %.0f context switches/s (%.1f per message it sends or "
        "receives, %.0f/s)\n",
        probe, r.threads, r.switches_per_s, r.switches_per_s / messages, messages);
    std::printf(
        "   bridge counters summed over the hubs (since start): out_dropped %llu, "
        "in_dropped %llu\n",
        (unsigned long long)r.out_dropped, (unsigned long long)r.in_dropped);
  };

  std::printf(
      "\n3. Fleet: %d hub processes, each with the bridge on a 3-node nats-server cluster; "
      "each exports %d channels of %zu B at %.0f Hz and imports one channel of every other "
      "hub\n   (hubs up and connected in %.1f s; every import flowing after %.1f s%s)\n",
      hubs, kChannels, kFleetPayload, kRateHz, boot_s, flow_s,
      silent > 0 ? (", " + std::to_string(silent) + " imports still silent").c_str() : "");
  std::printf(" a) steady, %.0f s\n", window_s);
  const Figures steady = measure([] {});
  print(steady);

  // The node that most hubs are connected to.
  std::map<std::string, int> on_node;
  for (auto& n : fleet_nodes) ++on_node[n->status()["server"].asString()];
  size_t victim = 0;
  int victim_hubs = -1;
  for (size_t k = 0; k < nodes.size(); ++k) {
    if (on_node[nodes[k]->url()] > victim_hubs) {
      victim = k;
      victim_hubs = on_node[nodes[k]->url()];
    }
  }
  std::printf(
      " b) node n%zu killed (SIGKILL) after %.1f s of %.0f s; %d of %d hubs were "
      "connected to it (hubs per node: n0 %d, n1 %d, n2 %d)\n",
      victim, window_s / 2, window_s, victim_hubs, hubs, on_node[nodes[0]->url()],
      on_node[nodes[1]->url()], on_node[nodes[2]->url()]);
  const Figures killed = measure([&] { nodes[victim]->kill(); });
  print(killed);
  sleepMs(1500);  // a status after the window
  int back = 0, elsewhere = 0;
  for (auto& n : fleet_nodes) {
    const Json::Value st = n->status();
    back += st["state"].asString() == "connected" ? 1 : 0;
    elsewhere += st["server"].asString() != nodes[victim]->url() ? 1 : 0;
  }
  std::printf("   afterwards: %d of %d bridges connected, %d on another node\n", back, hubs,
              elsewhere);

  // What the hubs logged about it.
  int overload = 0, errors = 0, slow = 0, reconnected = 0;
  auto count = [](const std::string& text, const std::string& what) {
    int n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
  };
  for (auto& p : procs) {
    const std::string log = p->log();
    overload += count(log, "LOOP-OVERLOAD");
    errors += count(log, "NATS-ERROR");
    slow += count(log, "Slow Consumer");
    reconnected += count(log, "NATS-RECONNECTED");
  }
  std::printf(
      "   hub logs: %d LOOP-OVERLOAD, %d NATS-ERROR (%d slow consumer), %d "
      "NATS-RECONNECTED\n",
      overload, errors, slow, reconnected);

  calling = false;
  caller.join();
  pacing = false;
  pacer.join();
  sleepMs(100);
  fleet_nodes.clear();
  for (auto& p : procs) p->stop();
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  int hubs = 0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--hubs") == 0 && i + 1 < argc) {
      hubs = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: nats_bridge [--quick] [--hubs N]\n");
      return 2;
    }
  }
  if (hubs == 0) hubs = quick ? 4 : 20;
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // in order with the warnings on stderr
  if (hubs < 2) fail("--hubs: at least 2");
  log::setLevel(log::Level::error);  // not this process's satellites starved of CPU
  const Nanos t0 = monotonicNs();
  {  // what else runs here colours every figure below
    const auto a = machineTicks();
    sleepMs(500);
    const auto b = machineTicks();
    std::printf(
        "Machine: %ld cores, %.0f%% busy with other work before the start\n\n",
        ::sysconf(_SC_NPROCESSORS_ONLN),
        double(b.first - a.first) / double(std::max<uint64_t>(1, b.second - a.second)) * 100);
  }
  skr::test::TempDir dir("skr-natsb");
  pointToPoint(dir.path(), quick);
  fleet(dir.path(), quick, hubs);
  std::printf("\n(whole run %.0f s)\n", double(monotonicNs() - t0) / 1e9);
  return 0;
}
