// SPDX-License-Identifier: Apache-2.0
// Boards on serial lines (docs/microcontrollers.md): an Arduino Uno running the board library
// (bench/serial/serial_bench.ino) in simavr at real-time speed, its UART on the hub's serial port,
// directly and through a relay that paces bytes at the line's rate (tests/boards/line_relay.c).
// For 115200 and 1,000,000 baud and payloads of 8, 32 and 128 bytes: messages per second and the
// share of the line's bytes (baud / 10 a second) that carry payload; and the latency from the
// board's publish to a subscriber's callback, half the round trip of a ping it echoes.
// Over UDP on loopback (server.udp, the board library's POSIX side, satellite/mcu/posix/skr_udp.h):
// a PING answered by the hub against a raw UDP echo measured in the same run, and the rate of
// 64-byte PUBLISHes a Unix-socket subscriber receives.
//
//   serial_udp [--quick]     --quick: one rate, shorter windows (the test suite's run)
#include "bench_satellite.h"
#include "sim_board.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/flow/codec.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "test_client.h"

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

// A UDP port free now on loopback.
uint16_t freeUdpPort() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

// Round trips of an 8-byte datagram through a thread that echoes it: the floor, in ms.
std::vector<double> rawUdpEcho(int n) {
  const int server = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ::bind(server, reinterpret_cast<sockaddr*>(&a), sizeof a);
  ::getsockname(server, reinterpret_cast<sockaddr*>(&a), &len);
  std::thread echo([&] {
    char buf[64];
    for (int i = 0; i < n; ++i) {
      sockaddr_in from{};
      socklen_t fl = sizeof from;
      const ssize_t got =
          ::recvfrom(server, buf, sizeof buf, 0, reinterpret_cast<sockaddr*>(&from), &fl);
      if (got > 0)
        ::sendto(server, buf, static_cast<size_t>(got), 0, reinterpret_cast<sockaddr*>(&from), fl);
    }
  });
  const int client = ::socket(AF_INET, SOCK_DGRAM, 0);
  ::connect(client, reinterpret_cast<sockaddr*>(&a), sizeof a);
  std::vector<double> rtt;
  char buf[64] = "12345678";
  for (int i = 0; i < n; ++i) {
    const Nanos t0 = monotonicNs();
    (void)!::send(client, buf, 8, 0);
    if (::recv(client, buf, sizeof buf, 0) == 8) {
      rtt.push_back(static_cast<double>(monotonicNs() - t0) / 1e6);
    }
  }
  echo.join();
  ::close(client);
  ::close(server);
  return rtt;
}

// A board's UDP session (the POSIX side of the board library) against the hub: PING round trips
// beside the raw echo, and the rate of PUBLISHes a socket subscriber receives.
bool measureUdp(const std::filesystem::path& dir, int pings, double window_s) {
  // The floor first, on an idle machine (the hub's loop polls busily after I/O).
  const std::vector<double> raw = rawUdpEcho(pings);
  const uint16_t port = freeUdpPort();
  const flow::UdpKey key{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};
  InProcessHub hub(dir, "udp", [&](flow::ServerOptions& o) {
    auto users = flow::UsersFile::load(o.users_file);
    if (!users || !users->add("robot", "unused-password") || !users->setUdpKey("robot", key) ||
        !users->save()) {
      std::exit(1);
    }
    flow::transport::UdpOptions udp;
    udp.address = "127.0.0.1";
    udp.port = port;
    o.udp = udp;
  });
  auto board = test::TestClient::overUdp("127.0.0.1", port, "robot", key);
  if (!board) {
    std::printf("udp: %s\n", board.error().message.c_str());
    return false;
  }
  if (!board->login("robot", "")) {
    std::printf("udp: the board's login failed\n");
    return false;
  }
  // Steady state: measured at once after the board's login, the first 200 pings take 4-5x the raw
  // echo (cause not found: the hub handles each in under 2 us); a second later, 1.1-1.2x.
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  std::vector<double> hub_rtt;
  for (int i = 0; i < pings; ++i) {
    const Nanos t0 = monotonicNs();
    auto r = board->call(flow::msg::Ping{{"12345678"}});
    if (r && r->kind() == flow::Code::reply_ok) {
      hub_rtt.push_back(static_cast<double>(monotonicNs() - t0) / 1e6);
    }
  }
  // The same PING over the hub's Unix socket: what the hub's loop costs without UDP.
  std::vector<double> unix_rtt;
  if (auto local = test::TestClient::connectUnix(hub.path());
      local && local->login("robot", "unused-password")) {
    for (int i = 0; i < pings; ++i) {
      const Nanos t0 = monotonicNs();
      auto r = local->call(flow::msg::Ping{{"12345678"}});
      if (r && r->kind() == flow::Code::reply_ok) {
        unix_rtt.push_back(static_cast<double>(monotonicNs() - t0) / 1e6);
      }
    }
  }
  std::printf(
      "udp       ping    the same PING over the hub's Unix socket: p50 %.1f us p99 %.1f us\n",
      percentile(unix_rtt, 0.5) * 1000, percentile(unix_rtt, 0.99) * 1000);
  const double raw50 = percentile(raw, 0.5), hub50 = percentile(hub_rtt, 0.5);
  std::printf(
      "udp       ping    hub p50 %.1f us p99 %.1f us; raw UDP echo p50 %.1f us p99 %.1f us; "
      "%.2fx\n",
      hub50 * 1000, percentile(hub_rtt, 0.99) * 1000, raw50 * 1000, percentile(raw, 0.99) * 1000,
      raw50 > 0 ? hub50 / raw50 : 0.0);
  // Throughput: the board publishes 64-byte payloads; a Unix-socket satellite counts them.
  if (!board->call(flow::msg::GoAsync{})) return false;
  flow::msg::ChanAdd add;
  add.tag = 1;
  add.kind = static_cast<uint8_t>(flow::ChannelKind::streaming);
  add.short_name = "stream";
  add.props = flow::Variant(flow::Variant::Map{});
  if (!board->send(add)) return false;
  auto added = test::as<flow::msg::EvChanAdded>(board->waitFor(flow::Code::ev_chan_added));
  if (!added) return false;
  Sat sub(hub, "reader");
  std::atomic<uint64_t> got{0};
  sub.on([&](sat::Satellite& s) {
    s.subscribe("robot.stream");
    s.dataView.connect(&s, [&](uint16_t, std::string_view) { ++got; });
  });
  if (!waitFor([&] {
        return sub.on([](sat::Satellite& s) { return s.channel("robot.stream") != nullptr; });
      })) {
    return false;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the subscription is in place
  const std::string payload(64, 'x');
  uint64_t sent = 0;
  const Nanos t0 = monotonicNs();
  const Nanos end = t0 + static_cast<Nanos>(window_s * 1e9);
  while (monotonicNs() < end) {
    (void)board->send(flow::msg::Publish{added->info.id, {payload}});
    ++sent;
    if (sent % 64 == 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  const double secs = static_cast<double>(monotonicNs() - t0) / 1e9;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last ones arrive
  // Every PUBLISH received was sent within the window: both rates over the window.
  std::printf("udp       64 B    sent %.0f msg/s, received %.0f msg/s (%.1f %% of those sent)\n",
              static_cast<double>(sent) / secs, static_cast<double>(got.load()) / secs,
              sent > 0 ? 100.0 * static_cast<double>(got.load()) / static_cast<double>(sent) : 0.0);
  return !hub_rtt.empty();
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
  std::printf("\nBoards over UDP on loopback\n");
  const bool udp_ok = measureUdp(dir.path(), quick ? 200 : 2000, quick ? 0.5 : 2.0);
  return ok && udp_ok ? 0 : 1;
}
