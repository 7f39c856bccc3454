// SPDX-License-Identifier: Apache-2.0
// FlowNetwork relay benchmark: what the hub costs compared with a direct socket between two
// clients. For the Unix socket, TCP and TLS over TCP (loopback), in the same run:
//   round trip   ping-pong A -> hub -> B -> hub -> A, one message in flight: p50/p99
//   1:1          delivered messages/s and MB/s from one publisher to one subscriber
//   fan-out 1:N  delivered messages/s in all and per subscriber, N = 4 and 16
// Every hub figure is printed next to its raw floor: the same framing and batching over a
// socketpair(AF_UNIX) or a loopback TCP connection, with no hub, and as a ratio to it. TLS rows
// run through a second hub whose TCP listener speaks TLS (certificates made at start by
// tests/support/make_test_certs.sh); their raw floor is a TLS session over a loopback TCP
// connection, and a last table puts each TLS figure next to plain TCP's through the hub.
//
// The hub runs in this process on its own LoopThread; clients are plain blocking sockets on
// their own threads. Publishers encode many PUBLISH frames into one buffer and send it with one
// send(); subscribers recv() large chunks and parse frames in place. A publisher never runs more
// than a window (4 MB) ahead of its slowest subscriber, so the figures are delivered traffic,
// not drops; drops (EV_DROPPED) are still counted and reported.
//
// Round trips alternate between raw and hub in blocks, so that load changes touch both alike.
//
//   flow_relay [--quick] [--seconds S] [--unix-only | --tcp-only | --no-tls] [--queue-mb M]
//              [--only round-trip|1:1|fan-out] [--busy-poll-us N]
//
// Exits 1 on a real error (lost connection, frames missing beyond the reported drops, a hub
// that does not answer); a missed target is reported, not an error.
#include <skrobot/runtime/log.h>

#include "relay_harness.h"

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace {

using namespace skr::bench;  // NOLINT(google-build-using-namespace): the harness is this file's
                             // vocabulary

// --- options -------------------------------------------------------------------------------

struct Options {
  bool quick = false;
  double seconds = 1.5;  // per throughput measurement (hub and raw each)
  bool unix_rows = true;
  bool tcp_rows = true;
  bool tls_rows = true;
  size_t queue_bytes = 8 * kMiB;  // ServerOptions::subscriber_queue_bytes
  std::string only;               // empty, "round-trip", "1:1" or "fan-out"
  long busy_poll_us = 50;         // the hub loop's busy_poll_us (50: the config default)
};

void usage() {
  std::printf(
      "usage: flow_relay [--quick] [--seconds S] [--unix-only | --tcp-only | --no-tls]\n"
      "                  [--queue-mb M]\n"
      "                  [--only round-trip|1:1|fan-out] [--busy-poll-us N]\n"
      "  --quick       a short run (a few seconds), used by the test suite as a smoke test\n"
      "  --seconds S   seconds per throughput measurement (default 1.5)\n"
      "  --unix-only   the Unix socket rows only; --tcp-only: TCP and TLS rows; --no-tls: no TLS\n"
      "  --queue-mb M  the hub's subscriber queue in MiB (default 8, the hub's default)\n"
      "  --only TEST   run one kind of test (for profiling)\n"
      "  --busy-poll-us N  the hub loop keeps polling N us after I/O (config loop.busy_poll_us)\n");
}

Options parseOptions(int argc, char** argv) {
  Options o;
  bool seconds_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--seconds" && has_value) {
      o.seconds = std::atof(argv[++i]);
      seconds_given = true;
    } else if (a == "--queue-mb" && has_value) {
      o.queue_bytes = static_cast<size_t>(std::atof(argv[++i]) * kMiB);
    } else if (a == "--busy-poll-us" && has_value) {
      o.busy_poll_us = std::atol(argv[++i]);
    } else if (a == "--only" && has_value) {
      o.only = argv[++i];
    } else if (a == "--unix-only") {
      o.tcp_rows = false;
      o.tls_rows = false;
    } else if (a == "--no-tls") {
      o.tls_rows = false;
    } else if (a == "--tcp-only") {
      o.unix_rows = false;
    } else {
      usage();
      std::exit(a == "--help" || a == "-h" ? 0 : 2);
    }
  }
  if (o.quick && !seconds_given) o.seconds = 0.08;
  const bool only_ok =
      o.only.empty() || o.only == "round-trip" || o.only == "1:1" || o.only == "fan-out";
  if (o.seconds <= 0 || o.queue_bytes < 64 * kKiB || (!o.unix_rows && !o.tcp_rows) || !only_ok) {
    usage();
    std::exit(2);
  }
  return o;
}

// --- rows ----------------------------------------------------------------------------------

enum class Kind { round_trip, stream };

struct Row {
  Transport transport = Transport::unix_socket;
  Kind kind = Kind::round_trip;
  size_t subscribers = 1;
  size_t payload = 0;
  Latency hub_rtt, raw_rtt;
  Throughput hub_tp, raw_tp;
};

std::string testText(const Row& r) {
  if (r.kind == Kind::round_trip) return "round trip";
  if (r.subscribers == 1) return "1:1";
  return "fan-out 1:" + std::to_string(r.subscribers);
}

std::string figureText(const Row& r, bool hub) {
  if (r.kind == Kind::round_trip) {
    const Latency& l = hub ? r.hub_rtt : r.raw_rtt;
    return fmt("p50 %.1f us  p99 %.1f us", l.p50_us, l.p99_us);
  }
  const Throughput& t = hub ? r.hub_tp : r.raw_tp;
  if (r.subscribers == 1) return rateText(t.total_rate) + fmt("  %.0f MB/s", t.mb_s);
  return rateText(t.total_rate) + " (" + rateText(t.per_sub_rate) + " per sub)";
}

std::string ratioText(const Row& r) {
  if (r.kind == Kind::round_trip) {
    return fmt("%.2fx (p99 %.2fx)", r.hub_rtt.p50_us / r.raw_rtt.p50_us,
               r.hub_rtt.p99_us / r.raw_rtt.p99_us);
  }
  return fmt("%.2fx", r.hub_tp.total_rate / r.raw_tp.total_rate);
}

void printHeader() {
  std::printf("%-5s %-12s %-6s %-31s %-31s %-19s %s\n", "", "test", "size", "hub", "raw floor",
              "hub/raw", "drops");
}

void printRow(const Row& r) {
  const std::string drops =
      r.kind == Kind::round_trip ? "-" : std::to_string(r.hub_tp.dropped + r.raw_tp.dropped);
  std::printf("%-5s %-12s %-6s %-31s %-31s %-19s %s\n", transportName(r.transport),
              testText(r).c_str(), sizeText(r.payload).c_str(), figureText(r, true).c_str(),
              figureText(r, false).c_str(), ratioText(r).c_str(), drops.c_str());
  std::fflush(stdout);
}

// both figures alike.
Row roundTripRow(const Hub& hub, Transport t, size_t payload, bool quick) {
  Row row{t, Kind::round_trip, 1, payload, {}, {}, {}, {}};
  const int blocks = quick ? 2 : 10;
  const int rounds = roundsFor(payload, quick) / blocks;
  const int warmup = std::max(20, rounds / 10);
  PingPair raw = rawPingPair(t);
  PingPair via_hub = hubPingPair(hub, t);
  std::vector<Nanos> raw_samples, hub_samples;
  for (int i = 0; i < blocks; ++i) {
    pingPong(raw, payload, rounds, warmup, raw_samples);
    pingPong(via_hub, payload, rounds, warmup, hub_samples);
  }
  row.raw_rtt = percentiles(raw_samples);
  row.hub_rtt = percentiles(hub_samples);
  return row;
}

Row streamRow(const Hub& hub, Transport t, size_t subscribers, size_t payload, double seconds) {
  Row row{t, Kind::stream, subscribers, payload, {}, {}, {}, {}};
  row.raw_tp = rawStream(t, subscribers, payload, seconds);
  row.hub_tp = hubStream(hub, t, subscribers, payload, seconds);
  return row;
}

void runTransport(const Hub& hub, Transport t, const Options& o, std::vector<Row>& rows) {
  const auto add = [&](Row r) {
    printRow(r);
    rows.push_back(r);
  };
  const auto wanted = [&](const char* test) { return o.only.empty() || o.only == test; };
  if (wanted("round-trip")) {
    for (size_t p : {16 * size_t{1}, kKiB, 64 * kKiB}) add(roundTripRow(hub, t, p, o.quick));
  }
  if (wanted("1:1")) {
    for (size_t p : {16 * size_t{1}, kKiB, 64 * kKiB, kMiB}) {
      add(streamRow(hub, t, 1, p, o.seconds));
    }
  }
  if (wanted("fan-out")) {
    for (size_t n : {size_t{4}, size_t{16}}) {
      for (size_t p : {16 * size_t{1}, kKiB}) add(streamRow(hub, t, n, p, o.seconds));
    }
  }
}

// --- report --------------------------------------------------------------------------------

const Row* findRow(const std::vector<Row>& rows, Kind kind, size_t subs, size_t payload) {
  for (const Row& r : rows) {
    if (r.transport == Transport::unix_socket && r.kind == kind && r.subscribers == subs &&
        r.payload == payload) {
      return &r;
    }
  }
  return nullptr;
}

void printTargets(const std::vector<Row>& rows) {
  std::printf("\ntargets (unix socket):\n");
  const Row* rtt = findRow(rows, Kind::round_trip, 1, 16);
  if (rtt == nullptr) {
    std::printf("  round trip 16 B within 2.5x the raw floor: not measured\n");
  } else {
    const double ratio = rtt->hub_rtt.p50_us / rtt->raw_rtt.p50_us;
    std::printf("  round trip 16 B within 2.5x the raw floor (p50): %.2fx -> %s\n", ratio,
                ratio <= 2.5 ? "met" : "NOT met");
  }
  const Row* tp = findRow(rows, Kind::stream, 1, 16);
  if (tp == nullptr) {
    std::printf("  1:1 16 B above 3 M msg/s: not measured\n");
  } else {
    const double rate = tp->hub_tp.total_rate;
    std::printf("  1:1 16 B above 3 M msg/s: %.2f M/s -> %s\n", rate / 1e6,
                rate > 3e6 ? "met" : "NOT met");
  }
}

// Each TLS row next to the plain TCP row of the same test through the hub: what encryption costs.
void printTlsAgainstTcp(const std::vector<Row>& rows) {
  bool header = false;
  for (const Row& tls : rows) {
    if (tls.transport != Transport::tls) continue;
    const Row* tcp = nullptr;
    for (const Row& r : rows) {
      if (r.transport == Transport::tcp && r.kind == tls.kind && r.subscribers == tls.subscribers &&
          r.payload == tls.payload) {
        tcp = &r;
      }
    }
    if (tcp == nullptr) continue;
    if (!header) {
      std::printf("\nTLS against plain TCP, both through the hub:\n");
      std::printf("%-12s %-6s %-31s %-31s %s\n", "test", "size", "tls", "tcp", "tls/tcp");
      header = true;
    }
    const std::string ratio =
        tls.kind == Kind::round_trip
            ? fmt("%.2fx (p99 %.2fx)", tls.hub_rtt.p50_us / tcp->hub_rtt.p50_us,
                  tls.hub_rtt.p99_us / tcp->hub_rtt.p99_us)
            : fmt("%.2fx", tls.hub_tp.total_rate / tcp->hub_tp.total_rate);
    std::printf("%-12s %-6s %-31s %-31s %s\n", testText(tls).c_str(), sizeText(tls.payload).c_str(),
                figureText(tls, true).c_str(), figureText(*tcp, true).c_str(), ratio.c_str());
  }
}

void printPreamble(const Options& o) {
  double load[3] = {0, 0, 0};
  if (::getloadavg(load, 3) < 0) load[0] = -1;
  std::printf(
      "flow_relay: hub on its own loop thread, clients on blocking sockets; %u cpus, load %.2f\n"
      "  round trip: one message in flight, %d/%d/%d round trips at 16 B/1 KB/64 KB\n"
      "  streaming: %.2f s per figure, %zu KB per send(), %zu KB recv buffer, publisher at most "
      "%zu MB ahead\n"
      "  hub subscriber queue %zu KB, hub loop busy_poll_us %ld; MB = 2^20 bytes of payload; "
      "drops = EV_DROPPED frames\n\n",
      std::thread::hardware_concurrency(), load[0], roundsFor(16, o.quick),
      roundsFor(kKiB, o.quick), roundsFor(64 * kKiB, o.quick), o.seconds, kBatchBytes / kKiB,
      kRecvBytes / kKiB, kWindowBytes / kMiB, o.queue_bytes / kKiB, o.busy_poll_us);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseOptions(argc, argv);
  // The hub writes with libuv (write(2), no MSG_NOSIGNAL): a client that closes while the hub
  // still writes to it would otherwise kill the whole process with SIGPIPE.
  std::signal(SIGPIPE, SIG_IGN);
  skr::log::setLevel(skr::log::Level::error);  // drops are reported in the table
  try {
    std::optional<Certificates> certs;
    if (o.tls_rows && o.tcp_rows) {
      certs.emplace();
      g_certs = &*certs;
    }
    Hub hub({o.queue_bytes, o.busy_poll_us, o.tcp_rows, false});
    std::optional<Hub> tls_hub;
    if (g_certs != nullptr) tls_hub.emplace(HubOptions{o.queue_bytes, o.busy_poll_us, true, true});
    printPreamble(o);
    printHeader();
    std::vector<Row> rows;
    if (o.unix_rows) runTransport(hub, Transport::unix_socket, o, rows);
    if (o.tcp_rows) runTransport(hub, Transport::tcp, o, rows);
    if (tls_hub) runTransport(*tls_hub, Transport::tls, o, rows);
    flow::ServerStats st = hub.stats();
    if (tls_hub) {
      const flow::ServerStats t = tls_hub->stats();
      st.frames_in += t.frames_in;
      st.data_frames_out += t.data_frames_out;
      st.data_frames_dropped += t.data_frames_dropped;
      st.protocol_errors += t.protocol_errors + t.tls_refused;
    }
    std::printf("\nhub: %llu frames in, %llu data frames out, %llu dropped, %llu protocol errors\n",
                static_cast<unsigned long long>(st.frames_in),
                static_cast<unsigned long long>(st.data_frames_out),
                static_cast<unsigned long long>(st.data_frames_dropped),
                static_cast<unsigned long long>(st.protocol_errors));
    printTlsAgainstTcp(rows);
    printTargets(rows);
    if (st.protocol_errors != 0) fail("the hub saw protocol errors");
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "flow_relay: error: %s\n", e.what());
    return 1;
  }
  return 0;
}