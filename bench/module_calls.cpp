// SPDX-License-Identifier: Apache-2.0
// A module's channel calls from its own thread (plugin ABI 1.10) against the same module on the
// hub's main loop, the baseline measured in the same run. A satellite publishes a message on
// guest.in; test_channel_echo (tests/modules/channel_echo.c) republishes it on its channel `out`
// and counts it in its database (db_set); the satellite times the round trip. On its own thread
// the module's data callback is posted to that thread, and its publish and db_set each cross
// back to the main loop and wait there (module_calls.h). Blocks of round trips alternate between
// the two, so that a change in the machine's load touches both.
//
//   module_calls [--quick] [--rounds N]   (N round trips per block, 4 blocks each; default 20000)
#include "relay_harness.h"

#include <skrobot/hub/module_host.h>
#include <skrobot/runtime/log.h>

#include <poll.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace skr::bench {
namespace {

constexpr size_t kPayload = 64;
constexpr int kBlocks = 4;

struct Options {
  int rounds = 20000;
  bool quick = false;
};

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      o.quick = true;
      o.rounds = 500;
    } else if (a == "--rounds" && i + 1 < argc) {
      o.rounds = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: module_calls [--quick] [--rounds N]\n");
      std::exit(2);
    }
  }
  if (o.rounds < 10) o.rounds = 10;
  return o;
}

// Whether a frame arrives within `ms` (something buffered counts).
bool readable(Peer& p, int ms) {
  pollfd fd{p.sock.fd(), POLLIN, 0};
  return ::poll(&fd, 1, ms) > 0;
}

// One block: the module loaded (on its own thread or not), round trips timed, the module stopped.
void runBlock(Hub& hub, Peer& sat, uint16_t in, bool own_thread, int rounds,
              std::vector<Nanos>& samples) {
  std::unique_ptr<ModuleHost> host;
  uint16_t out = 0;
  hub.onLoop([&](Loop& loop, flow::FlowServer& server) {
    host = std::make_unique<ModuleHost>(loop, std::vector<std::filesystem::path>{}, &server);
    ModuleEntry e;
    e.name = "test_channel_echo";
    e.path = std::filesystem::path(SKROBOT_TEST_MODULE_DIR) / "test_channel_echo.so";
    e.own_thread = own_thread;
    host->start({e});
    const auto probe = server.attachLocal("bench", "bench", {});
    if (auto id = probe->findChannel("test_channel_echo.out")) out = *id;
  });
  if (out == 0) fail("test_channel_echo did not start (see the log)");
  subscribe(sat, out);
  std::string ping;
  appendPublish(ping, in, kPayload);
  // The module hears of its first subscriber on its own thread: ping until it answers (echoes
  // come in order: those of earlier pings come before).
  uint64_t seq = 0;
  FrameView f;
  for (bool echoed = false; !echoed;) {
    if (seq == 200) fail("no echo from the module");
    stampSeq(ping.data(), ++seq);
    sat.send(ping);
    const Nanos until = monotonicNs() + 20'000'000;
    while (!echoed && monotonicNs() < until) {
      if (sat.in.tryNext(f)) {
        echoed = isData(f.code) && dataSeq(f, out, kPayload) == seq;
      } else if (readable(sat, 1)) {
        sat.in.fill();
      }
    }
  }
  for (int i = 0; i < rounds; ++i) {
    stampSeq(ping.data(), ++seq);
    const Nanos t0 = monotonicNs();
    sat.send(ping);
    do {
      f = sat.in.next();
    } while (!isData(f.code));
    if (dataSeq(f, out, kPayload) != seq) fail("wrong echo");
    samples.push_back(monotonicNs() - t0);
  }
  hub.onLoop([&](Loop&, flow::FlowServer&) { host.reset(); });
}

int run(const Options& o) {
  Hub hub({});
  PeerPtr sat = loginFlow(hub, Transport::unix_socket);
  const uint16_t in = addChannel(*sat, "in");
  std::vector<Nanos> main_loop, own_thread;
  for (int b = 0; b < kBlocks; ++b) {
    runBlock(hub, *sat, in, false, o.rounds, main_loop);
    runBlock(hub, *sat, in, true, o.rounds, own_thread);
  }
  const Latency m = percentiles(main_loop);
  const Latency t = percentiles(own_thread);
  std::printf(
      "module_calls: a 64-byte message through test_channel_echo (subscribe callback, "
      "publish, db_set), %d round trips per module placement over the Unix socket\n\n",
      kBlocks * o.rounds);
  std::printf("%-26s %10s %10s %14s\n", "module", "p50 us", "p99 us", "p50 vs main");
  std::printf("%-26s %10.1f %10.1f %14s\n", "on the main loop (floor)", m.p50_us, m.p99_us,
              "1.00x");
  std::printf("%-26s %10.1f %10.1f %13.2fx\n", "on its own thread", t.p50_us, t.p99_us,
              m.p50_us > 0 ? t.p50_us / m.p50_us : 0.0);
  std::printf(
      "\nown thread minus main loop, p50: %.1f us per message (a callback posted to the "
      "module's thread, two calls back to the main loop)\n",
      t.p50_us - m.p50_us);
  return 0;
}

}  // namespace
}  // namespace skr::bench

int main(int argc, char** argv) {
  const auto o = skr::bench::parseOptions(argc, argv);
  std::signal(SIGPIPE, SIG_IGN);
  skr::log::setLevel(skr::log::Level::error);
  try {
    return skr::bench::run(o);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "module_calls: error: %s\n", e.what());
    return 1;
  }
}
