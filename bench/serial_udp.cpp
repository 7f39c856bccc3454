// SPDX-License-Identifier: Apache-2.0
// Boards on serial lines (docs/microcontrollers.md): an Arduino Uno running the board library
// (bench/serial/serial_bench.ino) in simavr at real-time speed, its UART on the hub's serial port,
// directly and through a relay that paces bytes at the line's rate (tests/boards/line_relay.c).
// For 115200 and 1,000,000 baud and payloads of 8, 32 and 128 bytes: messages per second and the
// share of the line's bytes (baud / 10 a second) that carry payload; and the latency from the
// board's publish to a subscriber's callback, half the round trip of a ping it echoes.
//
//   serial_udp [--quick]     --quick: one rate, shorter windows (the test suite's run)
#include "bench_satellite.h"
#include "sim_board.h"

#include <skrobot/hub/flow/accounts.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <vector>

namespace {

using namespace skr;
using skr::bench::InProcessHub;
using skr::bench::Sat;
using skr::bench::waitFor;
using skr::boards::test::LineRelay;
using skr::boards::test::SimBoard;

struct Row {
  uint32_t baud = 0;
  bool relay = false;
  size_t size = 0;
  double msgs_per_s = 0, share = 0;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

// One board at `baud`, optionally behind a pacing relay; prints its rows.
bool measure(const std::filesystem::path& dir, uint32_t baud, const char* elf, bool relay,
             double window_s, int pings) {
  SimBoard board(SIMAVR_RUNNER_BIN, elf, dir);
  if (board.pty().empty()) {
    std::fprintf(stderr, "serial_udp: the simulator did not start: %s\n", board.output().c_str());
    std::exit(1);
  }
  std::unique_ptr<LineRelay> pacer;
  std::string device = board.pty();
  if (relay) {
    pacer = std::make_unique<LineRelay>(LINE_RELAY_BIN, board.pty(), dir,
                                        std::vector<std::string>{"--baud", std::to_string(baud)});
    device = pacer->pty();
  }
  const std::string name = "b" + std::to_string(baud) + (relay ? "r" : "d");
  InProcessHub hub(dir, name, [&](flow::ServerOptions& o) {
    auto users = flow::UsersFile::load(o.users_file);
    if (!users || !users->add("robot", "unused-password") || !users->save()) std::exit(1);
    flow::transport::SerialOptions port;
    port.device = device;
    port.baud = baud;
    port.account = "robot";
    o.serial.push_back(port);
  });
  Sat sub(hub, "reader");
  std::atomic<uint64_t> messages{0};
  std::mutex mutex;
  std::vector<Nanos> pong_at(static_cast<size_t>(pings) + 1, 0);
  sub.on([&](sat::Satellite& s) {
    (void)s.addChannel({.name = "ping"});
    s.subscribe("robot.bench");
    s.subscribe("robot.pong");
    s.dataView.connect(&s, [&, &s = s](uint16_t id, std::string_view payload) {
      const sat::ChannelInfo* c = s.channel(id);
      if (c == nullptr) return;
      if (c->name == "robot.bench") {
        ++messages;
      } else if (c->name == "robot.pong" && payload.size() >= 4) {
        uint32_t n = 0;
        std::memcpy(&n, payload.data(), 4);
        std::lock_guard lock(mutex);
        if (n < pong_at.size()) pong_at[n] = monotonicNs();
      }
    });
  });
  const auto subscribedTo = [&](const char* channel) {
    return waitFor(
        [&] { return sub.on([&](sat::Satellite& s) { return s.channel(channel) != nullptr; }); },
        60000);
  };
  if (!subscribedTo("robot.bench") || !subscribedTo("robot.pong") ||
      !subscribedTo("robot.control")) {
    std::fprintf(stderr, "serial_udp: the board did not log in\n%s\n", board.output().c_str());
    std::exit(1);
  }
  // The board's service; false (said on stdout) when it does not answer.
  const auto setSize = [&](int size) {
    std::optional<Result<flow::Variant>> r;
    sub.on([&](sat::Satellite& s) {
      r.emplace(s.call("robot.control", "size", flow::Variant(static_cast<int64_t>(size))));
    });
    if (!*r) {
      std::printf("%-9u %-7s robot.control: %s\n", baud, relay ? "relay" : "direct",
                  r->error().message.c_str());
    }
    return r->ok();
  };
  for (int size : {8, 32, 128}) {
    if (!setSize(size)) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the line fills
    const uint64_t before = messages.load();
    const Nanos t0 = monotonicNs();
    std::this_thread::sleep_for(std::chrono::duration<double>(window_s));
    const double secs = static_cast<double>(monotonicNs() - t0) / 1e9;
    const double rate = static_cast<double>(messages.load() - before) / secs;
    const double share = rate * size / (baud / 10.0);
    std::printf("%-9u %-7s %5d B %10.1f msg/s %8.0f B/s %8.1f %%\n", baud,
                relay ? "relay" : "direct", size, rate, rate * size, share * 100);
  }
  (void)setSize(0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<double> rtt_ms;
  for (int i = 1; i <= pings; ++i) {
    std::string payload(8, '\0');
    std::memcpy(payload.data(), &i, 4);
    const Nanos sent = monotonicNs();
    sub.on([&](sat::Satellite& s) { (void)s.publish("ping", payload); });
    const bool back = waitFor(
        [&] {
          std::lock_guard lock(mutex);
          return pong_at[static_cast<size_t>(i)] != 0;
        },
        2000);
    if (back) {
      std::lock_guard lock(mutex);
      rtt_ms.push_back(static_cast<double>(pong_at[static_cast<size_t>(i)] - sent) / 1e6);
    }
  }
  std::printf(
      "%-9u %-7s ping    round trip p50 %.2f ms p99 %.2f ms (%zu of %d); one way ~%.2f ms\n", baud,
      relay ? "relay" : "direct", percentile(rtt_ms, 0.5), percentile(rtt_ms, 0.99), rtt_ms.size(),
      pings, percentile(rtt_ms, 0.5) / 2);
  board.stop();
  std::printf("          simulator: %s\n",
              [&] {
                const std::string out = board.output();
                const size_t at = out.rfind("SIM ");
                return at == std::string::npos ? std::string("?")
                                               : out.substr(at, out.find('\n', at) - at);
              }()
                  .c_str());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  skr::test::TempDir dir("skrobot-bench-serial");
  std::printf(
      "Boards on serial lines: an Uno in simavr (real-time speed), the board library, the hub\n");
  std::printf("%-9s %-7s %7s %16s %12s %10s\n", "BAUD", "LINE", "PAYLOAD", "RATE", "PAYLOAD B/S",
              "SHARE");
  // The rate the quick run checks must work; the others are reported as they go.
  const bool ok = measure(dir.path(), 115200, SERIAL_BENCH_115200_ELF, false, quick ? 1.0 : 3.0,
                          quick ? 10 : 50);
  if (!quick) {
    measure(dir.path(), 115200, SERIAL_BENCH_115200_ELF, true, 3.0, 50);
    measure(dir.path(), 1000000, SERIAL_BENCH_1000000_ELF, false, 3.0, 50);
    measure(dir.path(), 1000000, SERIAL_BENCH_1000000_ELF, true, 3.0, 50);
  }
  return ok ? 0 : 1;
}
