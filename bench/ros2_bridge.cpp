// SPDX-License-Identifier: Apache-2.0
// The ros2-bridge module (docs/ros2.md, "The bridge") against a direct Fast DDS pair and one hub,
// in one run, all over UDPv4 on loopback (no shared memory on either side), at 64 B and 1 KB
// (sensor_msgs/msg/CompressedImage, that many bytes of data) and a 1920x1080 rgb8
// sensor_msgs/msg/Image (6,220,800 bytes of data):
//   direct:  a Fast DDS writer in a second process (this program, --peer) -> a Fast DDS reader here
//   hub:     a satellite -> the hub -> a satellite (the baseline: one hub hop)
//   ros2->hub: a Fast DDS writer -> the bridge's import (encoding cdr) -> a satellite
//   hub->ros2: a satellite -> the bridge's export (encoding cdr) -> a Fast DDS reader
// Each sample carries its send time (CLOCK_MONOTONIC, in header.stamp) and its sequence number
// (header.frame_id, 16 hex digits); the receiver takes the one-way latency from them. Per path and
// size: a paced phase (64 B and 1 KB: 1 kHz; the image: 30 Hz for 10 s) gives p50/p99 and, for the
// image, what was sent, received and missing; then a flood (each sender as fast as its writer or
// queue takes them) gives the delivered rate. Reliable QoS (ROS 2's default profile) everywhere;
// every participant, the bridge's included, asks for 8 MiB socket buffers (the kernel's grant is
// printed). Targets (issue 44): a bridged p50 within the direct p50 plus one hub hop's p50 (the
// ratio column: <= 1 meets it); 1080p at 30 Hz with nothing missing.
// The whole run is in a network namespace of its own (own_netns.h); the hub is a `skrobot` process.
//
//   ros2_bridge [--quick]
#include "dds_participant.h"
#include "hub_process.h"
#include "own_netns.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/spread.h>
#include <skrobot/support/json.hpp>

#include <dirent.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "bench_satellite.h"

namespace {

using namespace skr;
using namespace skr::ros2_bridge;
using bench::Sat;
using bench::waitFor;
using sat::test::Child;
using sat::test::HubProcess;
namespace fs = std::filesystem;

// Thrown on the main thread only, so that unwinding stops the hub and the peer (their
// destructors) before the process exits.
struct Failure : std::runtime_error {
  using std::runtime_error::runtime_error;
};
[[noreturn]] void fail(const std::string& why) {
  throw Failure(why);
}

void sleepUs(int64_t us) {
  std::this_thread::sleep_for(std::chrono::microseconds(us));
}

constexpr std::uint32_t kSocketBufferBytes = 8u << 20;
constexpr std::uint64_t kWarmUpSeq = ~std::uint64_t{0};  // not counted

// --- samples ------------------------------------------------------------------------------------

// What a case sends: a CompressedImage of `bytes` bytes of data, or the 1080p rgb8 Image.
struct Size {
  const char* label;  // also the topic's and channel's suffix
  std::size_t bytes;
  bool image;
  [[nodiscard]] const char* type() const {
    return image ? "sensor_msgs/msg/Image" : "sensor_msgs/msg/CompressedImage";
  }
};
constexpr Size kSizes[] = {{"64", 64, false}, {"1k", 1024, false}, {"img", 1920 * 1080 * 3, true}};

// Little-endian CDR after the 4-byte encapsulation header; alignment counts from the body.
class CdrOut {
 public:
  CdrOut() { out_.assign("\x00\x01\x00\x00", 4); }
  void u8(std::uint8_t v) { out_.push_back(char(v)); }
  void u32(std::uint32_t v) {
    align(4);
    out_.append(reinterpret_cast<const char*>(&v), 4);
  }
  void str(const std::string& s) {
    u32(std::uint32_t(s.size() + 1));
    out_.append(s);
    out_.push_back('\0');
  }
  void bytes(std::size_t n) {
    u32(std::uint32_t(n));
    out_.append(n, '\x5a');
  }
  std::string take() { return std::move(out_); }

 private:
  void align(std::size_t a) {
    while ((out_.size() - 4) % a != 0) out_.push_back('\0');
  }
  std::string out_;
};

// Where the stamp and the sequence number sit in every sample (header first in both types).
constexpr std::size_t kSecAt = 4, kNanosecAt = 8, kSeqAt = 16, kSeqDigits = 16;

std::string sampleTemplate(const Size& s, std::size_t data_bytes) {
  CdrOut c;
  c.u32(0);  // header.stamp.sec
  c.u32(0);  // header.stamp.nanosec
  c.str(std::string(kSeqDigits, '0'));
  if (s.image) {
    c.u32(1080);
    c.u32(1920);
    c.str("rgb8");
    c.u8(0);
    c.u32(1920 * 3);
  } else {
    c.str("raw");
  }
  c.bytes(data_bytes);
  return c.take();
}

// Stamps `sample` in place with its sequence number and the time now.
void stamp(std::string& sample, std::uint64_t seq) {
  char digits[kSeqDigits + 1];
  std::snprintf(digits, sizeof digits, "%016llx", static_cast<unsigned long long>(seq));
  std::memcpy(&sample[kSeqAt], digits, kSeqDigits);
  const Nanos now = monotonicNs();
  const auto sec = std::uint32_t(now / kNsPerSec), nanosec = std::uint32_t(now % kNsPerSec);
  std::memcpy(&sample[kSecAt], &sec, 4);
  std::memcpy(&sample[kNanosecAt], &nanosec, 4);
}

// The encoder against the types library: the same bytes as jsonToCdr without data, and a valid
// sample with data.
void checkEncoder() {
  ros2::Registry registry;
  if (!registry.addFolder(ros2::shippedFolder())) fail("no shipped ROS 2 interfaces");
  for (const Size& s : kSizes) {
    auto v = support::parseJson(
        s.image ? R"({"header": {"frame_id": "0000000000000000"}, "height": 1080,
                     "width": 1920, "encoding": "rgb8", "step": 5760})"
                : R"({"header": {"frame_id": "0000000000000000"}, "format": "raw"})");
    auto expected = ros2::jsonToCdr(registry, s.type(), *v);
    if (!expected || *expected != sampleTemplate(s, 0)) fail(std::string("encoder: ") + s.type());
    std::string full = sampleTemplate(s, s.bytes);
    stamp(full, 42);
    if (!ros2::validate(registry, s.type(), full)) fail(std::string("encoder: ") + s.type());
  }
}

// --- receiving ----------------------------------------------------------------------------------

// Receipts of one case, by sequence number: the latency of each (from its stamp) and when it
// came. Fed from one thread at a time (a Fast DDS receive thread, or a satellite's loop).
class Recorder {
 public:
  void reset(std::size_t expected) {
    std::lock_guard lock(m_);
    latency_us_.assign(expected, -1);
    at_.assign(expected, 0);
    got_ = 0;
    warm_ = 0;
    duplicates_ = 0;
  }
  void add(std::string_view sample) {
    const Nanos now = monotonicNs();
    if (sample.size() < kSeqAt + kSeqDigits) return;
    std::uint32_t sec = 0, nanosec = 0;
    std::memcpy(&sec, sample.data() + kSecAt, 4);
    std::memcpy(&nanosec, sample.data() + kNanosecAt, 4);
    const std::string digits(sample.substr(kSeqAt, kSeqDigits));
    const std::uint64_t seq = std::strtoull(digits.c_str(), nullptr, 16);
    std::lock_guard lock(m_);
    if (seq == kWarmUpSeq) {
      ++warm_;
      return;
    }
    if (seq >= at_.size()) return;
    if (at_[seq] != 0) {
      ++duplicates_;
      return;
    }
    at_[seq] = now;
    latency_us_[seq] = double(now - (Nanos(sec) * kNsPerSec + nanosec)) / 1e3;
    ++got_;
  }
  [[nodiscard]] std::uint64_t got() {
    std::lock_guard lock(m_);
    return got_;
  }
  [[nodiscard]] std::uint64_t warm() {
    std::lock_guard lock(m_);
    return warm_;
  }
  // Waits until every one of `expected` came, or nothing came for 2 s.
  void waitTail(std::uint64_t expected) {
    std::uint64_t seen = got();
    Nanos since = monotonicNs();
    while (got() < expected && monotonicNs() - since < 2 * kNsPerSec) {
      sleepUs(5000);
      if (got() != seen) {
        seen = got();
        since = monotonicNs();
      }
    }
  }
  // Latencies of [from, to) received.
  [[nodiscard]] Spread spread(std::size_t from, std::size_t to) {
    std::lock_guard lock(m_);
    std::vector<double> v;
    for (std::size_t i = from; i < to; ++i) {
      if (latency_us_[i] >= 0) v.push_back(latency_us_[i]);
    }
    return spreadOf(std::move(v));
  }
  [[nodiscard]] std::uint64_t received(std::size_t from, std::size_t to) {
    std::lock_guard lock(m_);
    std::uint64_t n = 0;
    for (std::size_t i = from; i < to; ++i) n += at_[i] != 0 ? 1 : 0;
    return n;
  }
  // Received per second in [from, to): from the first one's send to the last receipt.
  [[nodiscard]] double rate(std::size_t from, std::size_t to) {
    std::lock_guard lock(m_);
    Nanos first = 0, last = 0;
    std::uint64_t n = 0;
    for (std::size_t i = from; i < to; ++i) {
      if (at_[i] == 0) continue;
      const Nanos sent = at_[i] - Nanos(latency_us_[i] * 1e3);
      if (first == 0 || sent < first) first = sent;
      last = std::max(last, at_[i]);
      ++n;
    }
    return last > first ? double(n) / (double(last - first) / 1e9) : 0;
  }
  // Runs of missing sequence numbers in [from, to).
  [[nodiscard]] std::uint64_t gaps(std::size_t from, std::size_t to) {
    std::lock_guard lock(m_);
    std::uint64_t n = 0;
    for (std::size_t i = from; i < to; ++i) {
      if (at_[i] == 0 && (i == from || at_[i - 1] != 0)) ++n;
    }
    return n;
  }
  [[nodiscard]] std::uint64_t duplicates() {
    std::lock_guard lock(m_);
    return duplicates_;
  }

 private:
  std::mutex m_;
  std::vector<double> latency_us_;
  std::vector<Nanos> at_;
  std::uint64_t got_ = 0, warm_ = 0, duplicates_ = 0;
};

// --- sending ------------------------------------------------------------------------------------

// What each sender sends: `paced` samples every `period_us`, a pause, then `flood` back to back.
struct Plan {
  std::uint64_t paced = 0;
  std::int64_t period_us = 0;
  std::uint64_t flood = 0;
  [[nodiscard]] std::uint64_t total() const { return paced + flood; }
};

Plan planFor(const Size& s, bool quick) {
  if (s.image) return {quick ? 60u : 300u, 33333, quick ? 10u : 60u};  // 30 Hz for 2 s or 10 s
  return {quick ? 300u : 2000u, 1000, quick ? 2000u : 20000u};
}

// Sends `plan` through `send(sample)`, which returns false when the writer is full (then the same
// sample is tried again). Returns how many times it was full.
template <class Send>
std::uint64_t runPlan(const Plan& plan, std::string& sample, Send&& send) {
  std::uint64_t full = 0;
  const auto one = [&](std::uint64_t seq) {
    for (;;) {
      stamp(sample, seq);
      if (send(sample)) return;
      ++full;
      sleepUs(200);
    }
  };
  const Nanos start = monotonicNs();
  for (std::uint64_t i = 0; i < plan.paced; ++i) {
    const Nanos due = start + Nanos(i) * plan.period_us * 1000;
    while (monotonicNs() < due) sleepUs(std::min<Nanos>(200, (due - monotonicNs()) / 1000 + 1));
    one(i);
  }
  sleepUs(300000);
  for (std::uint64_t i = plan.paced; i < plan.total(); ++i) one(i);
  return full;
}

// --- DDS endpoints ------------------------------------------------------------------------------

std::unique_ptr<DdsParticipant> participant() {
  ParticipantConfig config;
  config.socket_buffer_bytes = kSocketBufferBytes;
  auto p = DdsParticipant::create(config);
  if (!p) fail("participant: " + p.error().message);
  return std::move(*p);
}

struct Matches {
  std::atomic<int> current{0};
};

EndpointId ddsWriter(DdsParticipant& p, const std::string& topic, const Size& s, Matches& m) {
  WriterCallbacks cb;
  cb.on_matched = [&m](const MatchStatus& st) { m.current = st.current; };
  auto id = p.createWriter(topic, s.type(), *qosProfile("default"), std::move(cb));
  if (!id) fail("writer " + topic + ": " + id.error().message);
  return *id;
}

EndpointId ddsReader(DdsParticipant& p, const std::string& topic, const Size& s, Recorder& into,
                     Matches& m) {
  ReaderCallbacks cb;
  cb.on_sample = [&into](Sample&& sample) { into.add(sample.bytes); };
  cb.on_matched = [&m](const MatchStatus& st) { m.current = st.current; };
  auto id = p.createReader(topic, s.type(), *qosProfile("default"), std::move(cb));
  if (!id) fail("reader " + topic + ": " + id.error().message);
  return *id;
}

// Sends `plan` through a DDS writer (retrying while its history is full).
std::uint64_t ddsSend(DdsParticipant& p, EndpointId w, const Size& s, const Plan& plan) {
  std::string sample = sampleTemplate(s, s.bytes);
  const std::uint64_t full = runPlan(plan, sample, [&](const std::string& b) {
    auto r = p.write(w, b);
    if (!r && r.error().code != Errc::timeout) fail("write: " + r.error().message);
    return bool(r);
  });
  (void)p.waitForAcknowledgments(w, 10000);
  return full;
}

// The direct pair's writer: `--peer <size label> <quick 0|1>`. Waits for the reader, sends
// warm-up samples for 300 ms, then the plan, and says so.
int peerMain(const std::string& label, bool quick) {
  const Size* size = nullptr;
  for (const Size& s : kSizes) size = label == s.label ? &s : size;
  if (size == nullptr) fail("peer: no size " + label);
  auto p = participant();
  Matches m;
  const EndpointId w = ddsWriter(*p, std::string("/bench_direct_") + size->label, *size, m);
  if (!waitFor([&] { return m.current > 0; }, 30000)) fail("peer: no reader");
  std::string warm = sampleTemplate(*size, size->bytes);
  for (int i = 0; i < 15; ++i) {
    stamp(warm, kWarmUpSeq);
    (void)p->write(w, warm);
    sleepUs(20000);
  }
  const std::uint64_t full = ddsSend(*p, w, *size, planFor(*size, quick));
  std::printf("PEER-DONE full=%llu\n", static_cast<unsigned long long>(full));
  return 0;
}

// --- satellites ---------------------------------------------------------------------------------

sat::ConnectOptions connectTo(const HubProcess& hub, const std::string& client) {
  sat::ConnectOptions o;
  o.address.kind = flow::Address::Kind::local;
  o.address.path = hub.socket().string();
  o.client_name = client;
  o.timeout_ms = 30000;
  return o;
}

// `sub` records what arrives on `name` into `into` (until the returned connection goes).
skr::Connection subscribeInto(Sat& sub, const std::string& name, Recorder& into) {
  skr::Connection conn;
  std::atomic<int> target{-1};
  sub.on([&](sat::Satellite& s) { s.subscribe(name, 64u << 20); });
  if (!waitFor([&] { return sub.on([&](sat::Satellite& s) { return s.isSubscribed(name); }); }))
    fail("cannot subscribe to " + name);
  const int id = sub.on([&](sat::Satellite& s) { return int(s.channelId(name).value_or(0)); });
  sub.on([&](sat::Satellite& s) {
    conn = s.dataView.connect(&s, [&into, id](uint16_t chan, std::string_view payload) {
      if (chan == id) into.add(payload);
    });
  });
  return conn;
}

// Sends `plan` on the satellite's channel `chan`, keeping at most 16 MiB queued.
std::uint64_t satSend(Sat& pub, const std::string& chan, const Size& s, const Plan& plan) {
  std::string sample = sampleTemplate(s, s.bytes);
  return runPlan(plan, sample, [&](const std::string& b) {
    return pub.on([&](sat::Satellite& sat) {
      return sat.queuedBytes() < (16u << 20) && bool(sat.publish(chan, b));
    });
  });
}

// Sends warm-up samples through `send` every 20 ms until `into` has one (the first samples of
// a fresh path wait for discovery and subscriptions).
template <class Send>
void warmUp(Recorder& into, const Size& s, Send&& send, const std::string& what) {
  std::string warm = sampleTemplate(s, s.bytes);
  if (!waitFor(
          [&] {
            stamp(warm, kWarmUpSeq);
            send(warm);
            sleepUs(20000);
            return into.warm() > 0;
          },
          20000)) {
    fail("nothing arrives through " + what);
  }
  sleepUs(200000);
}

// --- the granted socket buffers -----------------------------------------------------------------

// The largest SO_RCVBUF and SO_SNDBUF among this process's UDP sockets (Fast DDS's), as the
// kernel reports them (twice what it grants: the other half is its bookkeeping).
std::pair<int, int> udpBuffers() {
  int rcv = 0, snd = 0;
  for (const auto& e : fs::directory_iterator("/proc/self/fd")) {
    const int fd = std::atoi(e.path().filename().c_str());
    int type = 0, value = 0;
    socklen_t len = sizeof type;
    if (::getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &len) != 0 || type != SOCK_DGRAM) continue;
    len = sizeof value;
    if (::getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &value, &len) == 0) rcv = std::max(rcv, value);
    len = sizeof value;
    if (::getsockopt(fd, SOL_SOCKET, SO_SNDBUF, &value, &len) == 0) snd = std::max(snd, value);
  }
  return {rcv, snd};
}

std::string sysctl(const char* path) {
  std::ifstream in(path);
  std::string v;
  in >> v;
  return v;
}

// --- the run ------------------------------------------------------------------------------------

struct Figures {
  Spread latency;
  double rate = 0;
  std::uint64_t sent = 0, received = 0, gaps = 0, duplicates = 0, full = 0;
  std::uint64_t flood_lost = 0;  // of the flood: keep-last histories and hub queues drop
};

Figures figures(Recorder& r, const Plan& plan, std::uint64_t full) {
  r.waitTail(plan.total());
  Figures out;
  out.latency = r.spread(0, plan.paced);
  out.rate = r.rate(plan.paced, plan.total());
  out.sent = plan.paced;
  out.received = r.received(0, plan.paced);
  out.gaps = r.gaps(0, plan.paced);
  out.flood_lost = plan.flood - r.received(plan.paced, plan.total());
  out.duplicates = r.duplicates();
  out.full = full;
  return out;
}

enum Path { kDirect, kHub, kIn, kOut, kPaths };
constexpr const char* kPathNames[] = {"direct DDS", "hub hop", "ros2->hub", "hub->ros2"};

int run(bool quick) {
  checkEncoder();
  skr::test::TempDir dir;
  std::string imports, exports;
  for (const Size& s : kSizes) {
    imports += std::string(imports.empty() ? "" : ", ") + R"({"ros": "/bench_in_)" + s.label +
               R"(", "type": ")" + s.type() + R"(", "channel": "in_)" + s.label + R"("})";
    exports += std::string(exports.empty() ? "" : ", ") + R"({"channel": "guest.out_)" + s.label +
               R"(", "ros": "/bench_out_)" + s.label + R"(", "type": ")" + s.type() + R"("})";
  }
  HubProcess hub(SKROBOT_BIN, dir.path(), "", "", "",
                 R"([{"name": "ros2-bridge", "config": {"socket_buffer_bytes": )" +
                     std::to_string(kSocketBufferBytes) + R"(, "import": [)" + imports +
                     R"(], "export": [)" + exports + "]}}]");
  if (!hub.start()) fail("hub did not start:\n" + hub.log());
  if (!hub.waitLog("ROS2-BRIDGE")) fail("no bridge:\n" + hub.log());

  auto dds = participant();
  const auto [rcvbuf, sndbuf] = udpBuffers();
  Sat pub(connectTo(hub, "pub")), sub(connectTo(hub, "sub"));
  for (const Size& s : kSizes) {
    if (!pub.on([&](sat::Satellite& sat) {
          return bool(sat.addChannel({.name = std::string("base_") + s.label})) &&
                 bool(sat.addChannel({.name = std::string("out_") + s.label}));
        })) {
      fail("channels");
    }
  }

  std::printf("ros2_bridge%s: UDPv4 on loopback, no shared memory, reliable QoS (keep last 10)\n",
              quick ? " --quick" : "");
  std::printf(
      "socket buffers: asked %u B; the kernel reports SO_RCVBUF %d, SO_SNDBUF %d (twice the\n"
      "grant: net.core.rmem_max %s, wmem_max %s caps it; the bridge's participant asks the same)\n",
      kSocketBufferBytes, rcvbuf, sndbuf, sysctl("/proc/sys/net/core/rmem_max").c_str(),
      sysctl("/proc/sys/net/core/wmem_max").c_str());

  Figures results[kPaths][std::size(kSizes)];
  for (std::size_t si = 0; si < std::size(kSizes); ++si) {
    const Size& s = kSizes[si];
    const Plan plan = planFor(s, quick);
    Recorder rec;
    std::fprintf(stderr, "size %s ...\n", s.label);

    // Direct: the peer process writes, a reader here records.
    {
      rec.reset(plan.total());
      Matches m;
      const EndpointId r = ddsReader(*dds, std::string("/bench_direct_") + s.label, s, rec, m);
      Child peer({skr::test::selfExe(), "--peer", s.label, quick ? "1" : "0"}, {},
                 dir.path() / (std::string("peer-") + s.label + ".log"));
      if (peer.wait(300000) != 0 || peer.output().find("PEER-DONE") == std::string::npos) {
        fail("peer: " + peer.output());
      }
      const std::string out = peer.output();
      results[kDirect][si] =
          figures(rec, plan, std::strtoull(out.c_str() + out.find("full=") + 5, nullptr, 10));
      (void)dds->deleteEndpoint(r);
    }
    // The hub hop: pub's base_<size> -> sub.
    {
      rec.reset(plan.total());
      const std::string chan = std::string("base_") + s.label;
      skr::Connection conn = subscribeInto(sub, "guest." + chan, rec);
      warmUp(
          rec, s,
          [&](const std::string& b) {
            pub.on([&](sat::Satellite& sat) { (void)sat.publish(chan, b); });
          },
          "the hub");
      const std::uint64_t full = satSend(pub, chan, s, plan);
      results[kHub][si] = figures(rec, plan, full);
      sub.on([&](sat::Satellite& sat) {
        conn.disconnect();
        sat.unsubscribe("guest." + chan);
      });
    }
    // ROS 2 -> hub: a writer here -> the bridge's import -> sub.
    {
      rec.reset(plan.total());
      skr::Connection conn = subscribeInto(sub, std::string("ros2-bridge.in_") + s.label, rec);
      Matches m;
      const EndpointId w = ddsWriter(*dds, std::string("/bench_in_") + s.label, s, m);
      if (!waitFor([&] { return m.current > 0; }, 30000)) fail("the bridge's import: no match");
      warmUp(
          rec, s, [&](const std::string& b) { (void)dds->write(w, b); }, "the bridge's import");
      const std::uint64_t full = ddsSend(*dds, w, s, plan);
      results[kIn][si] = figures(rec, plan, full);
      (void)dds->deleteEndpoint(w);
      sub.on([&](sat::Satellite& sat) {
        conn.disconnect();
        sat.unsubscribe(std::string("ros2-bridge.in_") + s.label);
      });
    }
    // Hub -> ROS 2: pub's out_<size> -> the bridge's export -> a reader here.
    {
      rec.reset(plan.total());
      const std::string chan = std::string("out_") + s.label;
      Matches m;
      const EndpointId r = ddsReader(*dds, std::string("/bench_out_") + s.label, s, rec, m);
      if (!waitFor([&] {
            return pub.on([&](sat::Satellite& sat) { return sat.hasSubscribers(chan); });
          })) {
        fail("the bridge's export does not subscribe to " + chan + "\n" + hub.log());
      }
      warmUp(
          rec, s,
          [&](const std::string& b) {
            pub.on([&](sat::Satellite& sat) { (void)sat.publish(chan, b); });
          },
          "the bridge's export");
      const std::uint64_t full = satSend(pub, chan, s, plan);
      results[kOut][si] = figures(rec, plan, full);
      (void)dds->deleteEndpoint(r);
    }
  }

  std::printf(
      "\nOne way, send to receipt (us): paced (64 B, 1 KB: 1 kHz, %llu samples; image: 30 Hz,\n"
      "%llu samples); msgs/s: a flood of %llu (image: %llu), received per second.\n"
      "x target: bridged p50 / (direct p50 + hub hop p50); <= 1 meets the target.\n",
      static_cast<unsigned long long>(planFor(kSizes[0], quick).paced),
      static_cast<unsigned long long>(planFor(kSizes[2], quick).paced),
      static_cast<unsigned long long>(planFor(kSizes[0], quick).flood),
      static_cast<unsigned long long>(planFor(kSizes[2], quick).flood));
  std::printf("%-11s %-5s %10s %10s %10s %9s\n", "path", "size", "p50", "p99", "msgs/s",
              "x target");
  for (std::size_t si = 0; si < std::size(kSizes); ++si) {
    const double target = results[kDirect][si].latency.p50 + results[kHub][si].latency.p50;
    for (int p = 0; p < kPaths; ++p) {
      const Figures& r = results[p][si];
      std::printf("%-11s %-5s %10.1f %10.1f %10.0f", kPathNames[p], kSizes[si].label, r.latency.p50,
                  r.latency.p99, r.rate);
      if (p == kIn || p == kOut) std::printf(" %9.2f", target > 0 ? r.latency.p50 / target : 0);
      std::printf("\n");
    }
  }
  const Plan img = planFor(kSizes[2], quick);
  std::printf(
      "\n1080p rgb8 Image (%zu B of CDR) at 30 Hz for %.0f s: sent, received, missing\n"
      "(gaps: runs of missing sequence numbers); of the flood after it: lost, and the times the\n"
      "writer was full (a DDS write timed out, a satellite's queue held 16 MiB) and tried again\n",
      sampleTemplate(kSizes[2], kSizes[2].bytes).size(), double(img.paced) / 30);
  std::printf("%-11s %7s %9s %8s %6s %11s %6s\n", "path", "sent", "received", "missing", "gaps",
              "flood lost", "full");
  int missed = 0;
  for (int p = 0; p < kPaths; ++p) {
    const Figures& r = results[p][2];
    std::printf(
        "%-11s %7llu %9llu %8llu %6llu %11llu %6llu\n", kPathNames[p],
        static_cast<unsigned long long>(r.sent), static_cast<unsigned long long>(r.received),
        static_cast<unsigned long long>(r.sent - r.received),
        static_cast<unsigned long long>(r.gaps), static_cast<unsigned long long>(r.flood_lost),
        static_cast<unsigned long long>(r.full));
    missed += r.sent != r.received ? 1 : 0;
  }
  for (int p = 0; p < kPaths; ++p) {
    for (std::size_t si = 0; si < std::size(kSizes); ++si) {
      if (results[p][si].received == 0) fail(std::string("nothing received: ") + kPathNames[p]);
      if (results[p][si].duplicates > 0) {
        std::printf("%s %s: %llu samples received twice\n", kPathNames[p], kSizes[si].label,
                    static_cast<unsigned long long>(results[p][si].duplicates));
      }
    }
  }
  std::printf("\n%s\n", missed == 0 ? "1080p at 30 Hz: nothing missing on any path"
                                    : "1080p at 30 Hz: samples missing (above)");
  return 0;  // the satellites go first, then the participant, then the hub
}

}  // namespace

int main(int argc, char** argv) {
  if (const int failed = skr::test::enterOwnNetworkNamespace(argc, argv); failed != 0) {
    return failed;
  }
  if (argc >= 4 && std::string(argv[1]) == "--peer") {
    try {
      return peerMain(argv[2], argv[3][0] == '1');
    } catch (const Failure& e) {
      std::fprintf(stderr, "ros2_bridge --peer: %s\n", e.what());
      return 1;
    }
  }
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      quick = true;
    } else {
      std::fprintf(stderr, "usage: ros2_bridge [--quick]\n");
      return 2;
    }
  }
  try {
    return run(quick);
  } catch (const Failure& e) {
    std::fprintf(stderr, "ros2_bridge: %s\n", e.what());
    return 1;
  }
}
