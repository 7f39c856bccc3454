// SPDX-License-Identifier: Apache-2.0
// Hub links against one hub, in one run (docs/hub-links.md):
//   - service round trip p50/p99 at 16 B, 1 KB and 64 KB: the caller on the service's hub (one
//     hub), on a hub linked to it (one link), and on a hub linked to that one (two links);
//   - 1:1 streaming throughput at the same sizes over the same three paths (messages/s received,
//     and what the hubs dropped for a subscriber that fell behind);
//   - a 640x360 RGB video channel at 15 fps on one hub and across one link: frames delivered per
//     second and the latency from publish to receipt (one machine, one clock);
//   - a sync source at 100 Hz followed on each of the three paths at once: the followers' period
//     error and delay from the source, and the jitter one link adds;
//   - a blob download (64 MiB; --quick 8 MiB) on each path: MB/s against one hub's.
// Each hub is a FlowServer on a loop thread of its own; satellites are skr::sat::Satellite on
// their own loop threads, the caller a SyncClient. Two cores are shared by everything.
//
//   hub_link [--quick]
#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/spread.h>
#include <skrobot/satellite.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "bench_satellite.h"
#include "temp_dir.h"

namespace {

using namespace skr;
using bench::Sat;
using bench::sees;
using bench::waitFor;
using flow::Variant;

[[noreturn]] void fail(const std::string& why) {
  std::fprintf(stderr, "hub_link: %s\n", why.c_str());
  std::exit(1);
}

// A hub named `name` with the development account, linked to `to` (if any).
class Hub : public bench::InProcessHub {
 public:
  Hub(const std::filesystem::path& dir, const std::string& name, const Hub* to)
      : InProcessHub(dir, name,
                     [&](flow::ServerOptions& so) {
                       so.hub_name = name;
                       so.data_dir = dir / (name + "-data");
                       if (to == nullptr) return;
                       flow::HubLinkOptions link;
                       link.name = to->name_;
                       link.address = "local:" + to->path();
                       link.user = "guest";
                       link.password = "password";
                       so.links.push_back(link);
                     }),
        name_(name) {}

 private:
  std::string name_;
};

// --- service round trips ------------------------------------------------------------------------

// MB/s of downloads of `path` from the blob channel `channel` as seen on `hub` (the best of
// `runs`).
double download(const Hub& hub, const std::string& channel, const std::string& path, uint64_t size,
                int runs) {
  auto c = sat::SyncClient::connect(hub.connect("downloader"));
  if (!c) fail("downloader: " + c.error().message);
  auto info = c->channel(channel);
  if (!info) fail(channel + ": " + info.error().message);
  double best = 0;
  for (int i = 0; i < runs; ++i) {
    const Nanos start = monotonicNs();
    auto got =
        c->blobGetStream(info->id, path, [](std::string_view) -> Result<void> { return {}; });
    if (!got || *got != size)
      fail("download on " + channel + ": " + (got ? "short" : got.error().message));
    best = std::max(best, double(size) / 1e6 / (double(monotonicNs() - start) / 1e9));
  }
  return best;
}

Spread roundTrips(const Hub& hub, const std::string& service, size_t bytes, int count) {
  auto c = sat::SyncClient::connect(hub.connect("caller"));
  if (!c) fail("caller: " + c.error().message);
  const Variant payload(std::string(bytes, 'x'));
  std::vector<double> us;
  for (int i = 0; i < count + count / 10; ++i) {
    const Nanos t0 = monotonicNs();
    auto r = c->call(service, "echo", payload, 5000);
    if (!r) fail("call " + service + ": " + r.error().message);
    if (i >= count / 10) us.push_back(double(monotonicNs() - t0) / 1000.0);  // after a warm-up
  }
  return spreadOf(std::move(us));
}

// --- streaming ----------------------------------------------------------------------------------

struct Stream {
  double per_second =
      0;  // messages received per second, from the first publish to the last receipt
  uint64_t received = 0;
  uint64_t dropped = 0;  // sent but not received: dropped by a hub for a subscriber behind
};

// The publisher sends `total` messages of `bytes` as fast as its queue lets it; the receiver on
// `sub` counts them until the last arrives (or 20 s pass).
Stream stream(Sat& pub, Sat& sub, const std::string& name, size_t bytes, uint64_t total) {
  std::atomic<uint64_t> got{0};
  std::atomic<Nanos> last{0};
  skr::Connection conn;
  sub.on([&](sat::Satellite& s) {
    conn = s.data.connect(&s, [&](uint16_t, const std::string&) {
      ++got;
      last = monotonicNs();
    });
    s.subscribe(name);
  });
  if (!waitFor([&] { return pub.on([](sat::Satellite& s) { return s.hasSubscribers("load"); }); }))
    fail("no subscriber for " + name);
  const std::string payload(bytes, 'p');
  std::atomic<uint64_t> sent{0};
  // Publishes until its queue is full, then again on the loop's next turn.
  std::function<void()> burst = [&] {
    pub.on([&](sat::Satellite& s) {
      while (sent < total && s.queuedBytes() < (16u << 20)) {
        if (!s.publish("load", payload)) break;
        ++sent;
      }
    });
  };
  const Nanos first = monotonicNs();
  const Nanos t_end = first + 20 * kNsPerSec;
  while (sent < total && monotonicNs() < t_end) {
    burst();
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  waitFor([&] { return got >= total; }, 5000);
  const uint64_t dropped = sub.on([](sat::Satellite& s) { return s.stats().data_dropped; });
  sub.on([&](sat::Satellite& s) {
    s.unsubscribe(name);
    conn.disconnect();
  });
  waitFor([&] { return !pub.on([](sat::Satellite& s) { return s.hasSubscribers("load"); }); });
  Stream r;
  r.received = got;
  r.dropped = std::max<uint64_t>(dropped, total - std::min<uint64_t>(total, got));
  const double secs = double(last - first) / 1e9;
  r.per_second = secs > 0 ? double(got) / secs : 0;
  return r;
}

// --- video ------------------------------------------------------------------------------------

struct Video {
  double fps = 0;
  Spread latency_us;
};

Video video(Sat& pub, Sat& sub, const std::string& name, double seconds) {
  constexpr size_t kFrame = 640 * 360 * 3;
  std::vector<double> lat;
  std::mutex m;
  std::atomic<int> frames{0};
  skr::Connection conn;
  sub.on([&](sat::Satellite& s) {
    conn = s.data.connect(&s, [&](uint16_t, const std::string& payload) {
      Nanos sent = 0;
      std::memcpy(&sent, payload.data(), sizeof sent);
      std::lock_guard lock(m);
      lat.push_back(double(monotonicNs() - sent) / 1000.0);
      ++frames;
    });
    s.subscribe(name);
  });
  if (!waitFor([&] { return pub.on([](sat::Satellite& s) { return s.hasSubscribers("video"); }); }))
    fail("no subscriber for " + name);
  std::string frame(kFrame, 'v');
  const int count = int(seconds * 15);
  const Nanos t0 = monotonicNs();
  for (int i = 0; i < count; ++i) {
    std::this_thread::sleep_until(std::chrono::steady_clock::time_point(
        std::chrono::nanoseconds(t0 + Nanos(double(i) * 1e9 / 15))));
    const Nanos now = monotonicNs();
    std::memcpy(frame.data(), &now, sizeof now);
    if (!pub.on([&](sat::Satellite& s) { return bool(s.publish("video", frame)); }))
      fail("video publish");
  }
  waitFor([&] { return frames >= count; }, 3000);
  const double elapsed = double(monotonicNs() - t0) / 1e9;
  sub.on([&](sat::Satellite& s) {
    s.unsubscribe(name);
    conn.disconnect();
  });
  std::lock_guard lock(m);
  return Video{double(frames) / elapsed, spreadOf(lat)};
}

// --- the sync pulse across links -----------------------------------------------------------------

struct Pulses {
  size_t received = 0;
  uint64_t dropped = 0;
  Spread period_err_us, delay_us;
};

// A source on `owner` pulsing at `hz` for `seconds`, followed at once by each of `followers`
// (`names[i]` is the source's name where follower i is).
std::vector<Pulses> pulses(Sat& owner, const std::vector<Sat*>& followers,
                           const std::vector<std::string>& names, double hz, double seconds) {
  struct Seen {
    std::mutex m;
    std::vector<Nanos> arrivals;
    std::vector<double> delays;
    uint64_t dropped = 0;
    skr::Connection conn;
  };
  std::vector<std::unique_ptr<Seen>> seen;
  for (size_t i = 0; i < followers.size(); ++i) {
    seen.push_back(std::make_unique<Seen>());
    Seen& r = *seen.back();
    followers[i]->on([&](sat::Satellite& s) {
      r.conn = s.syncPulse.connect(&s, [&r](const sat::SyncPulse& p) {
        std::lock_guard lock(r.m);
        r.arrivals.push_back(p.arrival_ns);
        r.delays.push_back(double(p.arrival_ns - Nanos(p.source_time_ns)) / 1e3);
        r.dropped += p.dropped;
      });
      s.follow(names[i]);
    });
  }
  // Every follower gets pulses (across a link, once the link follows over there) before timing.
  const auto all = [&] {
    for (auto& r : seen) {
      std::lock_guard lock(r->m);
      if (r->arrivals.empty()) return false;
    }
    return true;
  };
  for (int i = 0; i < 500 && !all(); ++i) {
    (void)owner.on([](sat::Satellite& s) { return bool(s.pulse("clock")); });
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (!all()) fail("a follower got no pulse");
  for (auto& r : seen) {
    std::lock_guard lock(r->m);
    r->arrivals.clear();
    r->delays.clear();
    r->dropped = 0;
  }
  const int count = int(seconds * hz);
  const Nanos t0 = monotonicNs();
  for (int i = 0; i < count; ++i) {
    std::this_thread::sleep_until(std::chrono::steady_clock::time_point(
        std::chrono::nanoseconds(t0 + Nanos(double(i) * 1e9 / hz))));
    if (!owner.on([](sat::Satellite& s) { return bool(s.pulse("clock")); })) fail("pulse");
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::vector<Pulses> out;
  for (size_t i = 0; i < followers.size(); ++i) {
    followers[i]->on([&](sat::Satellite& s) {
      s.unfollow(names[i]);
      seen[i]->conn.disconnect();
    });
    std::lock_guard lock(seen[i]->m);
    out.push_back(Pulses{seen[i]->arrivals.size(), seen[i]->dropped,
                         spreadOf(periodErrorsUs(seen[i]->arrivals, 1e9 / hz)),
                         spreadOf(seen[i]->delays)});
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  log::setLevel(log::Level::warn);
  skr::test::TempDir dir;
  // h2 -> h1 -> h0: a caller on h1 is one link away from h0, on h2 two.
  Hub h0(dir.path(), "h0", nullptr);
  Hub h1(dir.path(), "h1", &h0);
  Hub h2(dir.path(), "h2", &h1);

  Sat owner(h0, "owner");
  if (!owner.on([](sat::Satellite& s) {
        return bool(s.addChannel({.name = "echo", .kind = flow::ChannelKind::service})) &&
               bool(s.addChannel({.name = "load"})) && bool(s.addChannel({.name = "video"})) &&
               bool(s.addChannel({.name = "clock", .kind = flow::ChannelKind::sync}));
      })) {
    fail("owner channels");
  }
  owner.on([](sat::Satellite& s) {
    s.serviceRequest.connect(&s, [&s](const sat::Request& r) { (void)s.respond(r, r.value); });
  });
  Sat on_h0(h0, "sub0");
  Sat on_h1(h1, "sub1");
  Sat on_h2(h2, "sub2");
  if (!waitFor([&] { return sees(on_h2, "h0/guest.load") && sees(on_h1, "h0/guest.echo"); }))
    fail("the links did not bring h0's channels");

  struct Path {
    const char* name;
    const Hub& hub;
    Sat& sub;
    std::string prefix;
  };
  const Path paths[] = {
      {"one hub", h0, on_h0, ""}, {"one link", h1, on_h1, "h0/"}, {"two links", h2, on_h2, "h0/"}};
  const int calls = quick ? 200 : 3000;
  std::printf("Service round trip (us), %d calls each; ratio: p50 against one hub's\n", calls);
  std::printf("%-8s %-10s %9s %9s %9s %7s\n", "size", "path", "p50", "p99", "max", "ratio");
  double worst_rtt_ratio = 0;
  for (size_t bytes : {size_t(16), size_t(1024), size_t(65536)}) {
    double base = 0;
    for (const Path& p : paths) {
      const Spread s = roundTrips(p.hub, p.prefix + "guest.echo", bytes, calls);
      if (base == 0) base = s.p50;
      const double ratio = s.p50 / base;
      if (std::strcmp(p.name, "one link") == 0) worst_rtt_ratio = std::max(worst_rtt_ratio, ratio);
      std::printf("%-8zu %-10s %9.1f %9.1f %9.1f %7.2f\n", bytes, p.name, s.p50, s.p99, s.max,
                  ratio);
    }
  }

  std::printf("\n1:1 streaming, received messages/s; ratio against one hub's\n");
  std::printf("%-8s %-10s %12s %10s %9s %9s %7s\n", "size", "path", "msgs/s", "MB/s", "received",
              "lost", "ratio");
  double worst_tput_ratio = 1e9;
  for (size_t bytes : {size_t(16), size_t(1024), size_t(65536)}) {
    const uint64_t total = quick ? 2000 : (bytes >= 65536 ? 20000 : 500000);
    double base = 0;
    for (const Path& p : paths) {
      const Stream s = stream(owner, p.sub, p.prefix + "guest.load", bytes, total);
      if (base == 0) base = s.per_second;
      const double ratio = s.per_second / base;
      if (std::strcmp(p.name, "one link") == 0)
        worst_tput_ratio = std::min(worst_tput_ratio, ratio);
      std::printf("%-8zu %-10s %12.0f %10.1f %9llu %9llu %7.2f\n", bytes, p.name, s.per_second,
                  s.per_second * double(bytes) / 1e6, (unsigned long long)s.received,
                  (unsigned long long)s.dropped, ratio);
    }
  }

  const double secs = quick ? 1 : 5;
  std::printf("\n640x360 RGB video at 15 fps for %.0f s: frames/s delivered, latency (us)\n", secs);
  std::printf("%-10s %7s %9s %9s %9s\n", "path", "fps", "p50", "p99", "max");
  for (const Path& p : {paths[0], paths[1]}) {
    const Video v = video(owner, p.sub, p.prefix + "guest.video", secs);
    std::printf("%-10s %7.1f %9.0f %9.0f %9.0f\n", p.name, v.fps, v.latency_us.p50,
                v.latency_us.p99, v.latency_us.max);
  }
  const double hz = 100;
  std::printf(
      "\nA sync source at %.0f Hz for %.0f s, followed on each path at once: period "
      "error and source-to-follower delay (us)\n",
      hz, secs);
  std::printf("%-10s %9s %8s %9s %9s %9s %9s\n", "path", "pulses", "dropped", "err p50", "err p99",
              "delay p50", "delay p99");
  const auto got = pulses(owner, {&on_h0, &on_h1, &on_h2},
                          {"guest.clock", "h0/guest.clock", "h0/guest.clock"}, hz, secs);
  for (size_t i = 0; i < got.size(); ++i) {
    const Pulses& p = got[i];
    std::printf("%-10s %9zu %8llu %9.1f %9.1f %9.1f %9.1f\n", paths[i].name, p.received,
                (unsigned long long)p.dropped, p.period_err_us.p50, p.period_err_us.p99,
                p.delay_us.p50, p.delay_us.p99);
  }
  std::printf(
      "jitter a link adds (period error p99, one link minus one hub): %.1f us; delay p50 "
      "it adds: %.1f us\n",
      got[1].period_err_us.p99 - got[0].period_err_us.p99,
      got[1].delay_us.p50 - got[0].delay_us.p50);
  const uint64_t blob_bytes = quick ? (8u << 20) : (64u << 20);
  {
    auto c = sat::SyncClient::connect(h0.connect("uploader"));
    if (!c) fail("uploader: " + c.error().message);
    auto ch = c->createBlobChannel("maps");
    if (!ch) fail("blob channel: " + ch.error().message);
    if (auto r = c->blobPut(ch->id, "map.bin", std::string(blob_bytes, 'm')); !r) {
      fail("upload: " + r.error().message);
    }
  }
  if (!waitFor([&] { return sees(on_h2, "h0/guest.maps"); })) fail("h0/guest.maps not seen on h2");
  std::printf("\nBlob download of %llu MiB (best of 3), MB/s; ratio against one hub's\n",
              (unsigned long long)(blob_bytes >> 20));
  std::printf("%-10s %9s %7s\n", "path", "MB/s", "ratio");
  double blob_base = 0;
  for (const Path& p : paths) {
    const double mbs = download(p.hub, p.prefix + "guest.maps", "map.bin", blob_bytes, 3);
    if (blob_base == 0) blob_base = mbs;
    std::printf("%-10s %9.0f %7.2f\n", p.name, mbs, mbs / blob_base);
  }
  std::printf(
      "\nTargets: one link's round trip p50 within 2x one hub's (worst %.2fx: %s); "
      "throughput through one link at least 0.5x one hub's (worst %.2fx: %s)\n",
      worst_rtt_ratio, worst_rtt_ratio <= 2 ? "met" : "NOT met", worst_tput_ratio,
      worst_tput_ratio >= 0.5 ? "met" : "NOT met");
  std::fflush(stdout);
  return 0;
}
