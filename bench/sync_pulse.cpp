// SPDX-License-Identifier: Apache-2.0
// The sync pulse through the hub, in one run: a source at 100 Hz and at 1 kHz, followed by 1, 10
// and 50 target processes, with and without a 15 fps 640x360 RGB stream going to the same
// targets. Per row: the source's own period error, the targets' period error and source-to-target
// delay (the worst target's p50/p99/max), and the pulses dropped and missed.
//
//   sync_pulse [--quick] [--seconds S]      each row S seconds (default 10: a p99 of 1000
//                                           pulses at 100 Hz, not of a few hundred);
//                                           --quick: 100 Hz, 1 and 10 targets, 1 s each
//
// The target is checked on the row 100 Hz, 10 targets, no video: the worst target's p99
// period error at most the source's own p99 + 100 us, and no pulse dropped or missed.
//
// Targets are processes of this binary (--target): each follows the source with a Satellite and
// answers each pulse at once (a target that keeps up), and reports its figures on stdout.
#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/spread.h>
#include <skrobot/satellite/satellite.h>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "temp_dir.h"

extern char** environ;

namespace {

using namespace skr;

[[noreturn]] void fail(const std::string& why) {
  std::fprintf(stderr, "sync_pulse: %s\n", why.c_str());
  std::exit(1);
}

sat::SatelliteOptions options(const std::string& socket, const std::string& name) {
  sat::SatelliteOptions o;
  o.connection.address = sat::Address::parse("local:" + socket).value();
  o.connection.client_name = name;
  o.connection.user = "bench";  // the hub's development account
  o.reconnect = false;
  return o;
}

// --- a target process -------------------------------------------------------------------------

// Follows bench.clock (and subscribes to bench.video with `video`), prints "ready", then, once the
// pulses stop for 1 s: "<pulses> <dropped> <missed> <err p50> <p99> <max> <delay p50> <p99> <max>".
int runTarget(const std::string& socket, double hz, bool video) {
  Loop loop(LoopOptions{.name = "target", .fast_interval_ns = 100 * kNsPerMs});
  sat::Satellite s(loop, options(socket, "target"));
  std::vector<Nanos> arrivals;
  std::vector<double> delays;
  uint64_t dropped = 0, missed = 0, last = 0, frames = 0;
  bool ready = false;
  s.subscribed.connect(&s, [&](const sat::ChannelInfo& info) {
    if (info.name == "bench.clock") (void)s.syncDatabases();  // a round trip: following now
  });
  s.databasesSynced.connect(&s, [&](uint32_t) {
    if (ready) return;
    ready = true;
    std::printf("ready\n");
    std::fflush(stdout);
  });
  s.syncPulse.connect(&s, [&](const sat::SyncPulse& p) {
    if (last != 0 && p.seq > last + 1 + p.dropped) missed += p.seq - last - 1 - p.dropped;
    last = p.seq;
    dropped += p.dropped;
    arrivals.push_back(p.arrival_ns);
    delays.push_back(double(p.arrival_ns - Nanos(p.source_time_ns)) / 1e3);
  });
  s.data.connect(&s, [&](uint16_t, const std::string&) { ++frames; });
  s.follow("bench.clock");
  if (video) s.subscribe("bench.video");
  const Nanos started = monotonicNs();
  loop.addTickHandler(Tick::fast, [&] {
    const Nanos now = monotonicNs();
    if (!arrivals.empty() && now - arrivals.back() > kNsPerSec) loop.stop();
    if (now - started > 60 * kNsPerSec) loop.stop();  // never left behind
  });
  s.start();
  loop.run();
  const Spread err = spreadOf(periodErrorsUs(arrivals, 1e9 / hz));
  const Spread delay = spreadOf(delays);
  std::printf("%zu %llu %llu %.1f %.1f %.1f %.1f %.1f %.1f %llu\n", arrivals.size(),
              (unsigned long long)dropped, (unsigned long long)missed, err.p50, err.p99, err.max,
              delay.p50, delay.p99, delay.max, (unsigned long long)frames);
  return 0;
}

// --- the parent -------------------------------------------------------------------------------

struct Target {
  pid_t pid = 0;
  FILE* out = nullptr;
};

Target spawnTarget(const std::string& socket, double hz, bool video) {
  int fds[2];
  if (::pipe(fds) != 0) fail("pipe");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  const std::string hz_text = std::to_string(hz);
  std::vector<std::string> args{"sync_pulse", "--target", socket, hz_text, video ? "1" : "0"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  Target t;
  if (posix_spawn(&t.pid, "/proc/self/exe", &actions, nullptr, argv.data(), environ) != 0) {
    fail("spawn a target");
  }
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  t.out = ::fdopen(fds[0], "r");
  return t;
}

std::string readLine(FILE* f) {
  char buf[512];
  if (std::fgets(buf, sizeof buf, f) == nullptr) return {};
  return buf;
}

struct Row {
  double hz = 0;
  int targets = 0;
  bool video = false;
  Spread source;
  double err_p50 = 0, err_p99 = 0, err_max = 0, delay_p50 = 0, delay_p99 = 0, delay_max = 0;
  uint64_t sent = 0, got_min = ~0ull, dropped = 0, missed = 0;
};

Row runOnce(const std::string& socket, double hz, int targets, bool video, double seconds) {
  Row row;
  row.hz = hz;
  row.targets = targets;
  row.video = video;
  std::vector<Target> procs;
  for (int i = 0; i < targets; ++i) procs.push_back(spawnTarget(socket, hz, video));
  // The source and the camera, each on a loop of its own.
  LoopThread source_thread(
      LoopOptions{.name = "source",
                  .mode = hz > 100 ? TimingMode::pseudo_realtime : TimingMode::coarse,
                  .fast_interval_ns = Nanos(1e9 / hz)});
  LoopThread camera_thread(LoopOptions{.name = "camera", .fast_interval_ns = Nanos(1e9 / 15)});
  std::unique_ptr<sat::Satellite> source, camera;
  std::atomic<bool> pulsing{false};
  std::vector<Nanos> sent;
  source_thread.start();
  camera_thread.start();
  source_thread.loop().invoke([&] {
    source = std::make_unique<sat::Satellite>(source_thread.loop(), options(socket, "source"));
    (void)source->addChannel({.name = "clock", .kind = flow::ChannelKind::sync});
    source->start();
    source_thread.loop().addTickHandler(Tick::fast, [&] {
      if (!pulsing || !source->pulse("clock")) return;
      sent.push_back(monotonicNs());
    });
  });
  const std::string frame(640 * 360 * 3, 'v');
  if (video) {
    camera_thread.loop().invoke([&] {
      camera = std::make_unique<sat::Satellite>(camera_thread.loop(), options(socket, "camera"));
      (void)camera->addChannel({.name = "video", .mime = "image/x-rgb"});
      camera->start();
      camera_thread.loop().addTickHandler(Tick::fast, [&] {
        if (pulsing && camera->hasSubscribers("video")) (void)camera->publish("video", frame);
      });
    });
  }
  for (auto& t : procs) {
    if (readLine(t.out).rfind("ready", 0) != 0) fail("a target did not start");
  }
  pulsing = true;
  ::usleep(useconds_t(seconds * 1e6));
  pulsing = false;
  for (auto& t : procs) {
    const std::string line = readLine(t.out);
    unsigned long long got = 0, dropped = 0, missed = 0, frames = 0;
    double e50 = 0, e99 = 0, emax = 0, d50 = 0, d99 = 0, dmax = 0;
    if (std::sscanf(line.c_str(), "%llu %llu %llu %lf %lf %lf %lf %lf %lf %llu", &got, &dropped,
                    &missed, &e50, &e99, &emax, &d50, &d99, &dmax, &frames) != 10) {
      fail("a target's report: " + line);
    }
    row.got_min = std::min<uint64_t>(row.got_min, got);
    row.dropped += dropped;
    row.missed += missed;
    row.err_p50 = std::max(row.err_p50, e50);
    row.err_p99 = std::max(row.err_p99, e99);
    row.err_max = std::max(row.err_max, emax);
    row.delay_p50 = std::max(row.delay_p50, d50);
    row.delay_p99 = std::max(row.delay_p99, d99);
    row.delay_max = std::max(row.delay_max, dmax);
    std::fclose(t.out);
    int status = 0;
    ::waitpid(t.pid, &status, 0);
  }
  source_thread.loop().invoke([&] { source.reset(); });
  if (video) camera_thread.loop().invoke([&] { camera.reset(); });
  row.sent = sent.size();
  row.source = spreadOf(periodErrorsUs(sent, 1e9 / hz));
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 5 && std::string(argv[1]) == "--target") {
    return runTarget(argv[2], std::atof(argv[3]), std::string(argv[4]) == "1");
  }
  bool quick = false;
  double seconds = 10;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      quick = true;
      seconds = 1;
    } else if (a == "--seconds" && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: sync_pulse [--quick] [--seconds S]\n");
      return 2;
    }
  }
  test::TempDir dir;
  flow::ServerOptions so;
  so.app_name = "skrobot-sync-bench-" + std::to_string(::getpid());
  so.unix_path = (dir.path() / "hub.sock").string();
  so.data_dir = dir.path() / "data";
  so.dev_account = std::make_pair(std::string("bench"), std::string("password"));
  LoopThread hub_thread(LoopOptions{.name = "hub"});
  hub_thread.start();
  std::unique_ptr<flow::FlowServer> server;
  Result<void> started;
  hub_thread.loop().invoke([&] {
    server = std::make_unique<flow::FlowServer>(hub_thread.loop(), so);
    started = server->start();
  });
  if (!started) fail("hub: " + started.error().message);

  std::printf("%-6s %-7s %-5s %7s | %22s | %22s | %22s | %9s\n", "rate", "targets", "video",
              "pulses", "source err p50/p99/max", "target err p50/p99/max", "delay p50/p99/max",
              "drop/miss");
  const std::vector<double> rates =
      quick ? std::vector<double>{100} : std::vector<double>{100, 1000};
  const std::vector<int> counts = quick ? std::vector<int>{1, 10} : std::vector<int>{1, 10, 50};
  std::optional<Row> gate;  // 100 Hz, 10 targets, no video
  for (const double hz : rates) {
    for (const int n : counts) {
      for (const bool video : {false, true}) {
        if (quick && video && n > 1) continue;
        const Row r = runOnce(so.unix_path, hz, n, video, seconds);
        if (hz == 100 && n == 10 && !video) gate = r;
        std::printf(
            "%-6.0f %-7d %-5s %7llu | %6.0f %7.0f %7.0f us | %6.0f %7.0f %7.0f us | %6.0f %7.0f "
            "%7.0f us | %4llu/%llu\n",
            hz, n, video ? "yes" : "no", (unsigned long long)r.sent, r.source.p50, r.source.p99,
            r.source.max, r.err_p50, r.err_p99, r.err_max, r.delay_p50, r.delay_p99, r.delay_max,
            (unsigned long long)r.dropped, (unsigned long long)r.missed);
        std::fflush(stdout);
      }
    }
  }
  std::printf(
      "\n(target columns: the worst target's figure; 2 cores are shared by the hub, the "
      "source, the camera and every target)\n");
  if (gate) {
    const bool met =
        gate->err_p99 <= gate->source.p99 + 100 && gate->dropped == 0 && gate->missed == 0;
    std::printf(
        "target at 100 Hz, 10 targets, no video: worst target p99 %.0f us vs source p99 %.0f us "
        "+ 100 us, %llu dropped, %llu missed over %llu pulses: %s\n",
        gate->err_p99, gate->source.p99, (unsigned long long)gate->dropped,
        (unsigned long long)gate->missed, (unsigned long long)gate->sent, met ? "met" : "NOT met");
  }
  hub_thread.loop().invoke([&] { server.reset(); });
  return 0;
}
