// SPDX-License-Identifier: Apache-2.0
// Blob channels with the real hub process: a large round trip checked by sha256 while the hub's
// resident memory is sampled, and kill -9 in the middle of an upload.
//   BLOB_MB   size of the round trip in MiB (default 256, 32 in the AddressSanitizer build; 2048
//             for the long run)
#include "hub_process.h"  // Child
#include "sat_fixture.h"  // SatOnThread
#include "temp_dir.h"

#include <skrobot/satellite/sync_client.h>

#include <gtest/gtest.h>
#include <sodium.h>

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>

#ifndef BLOB_MB_DEFAULT
#define BLOB_MB_DEFAULT 256
#endif

namespace {

namespace fs = std::filesystem;
using namespace skr;
using skr::sat::SyncClient;
using skr::test::TempDir;

// The resident memory of process `pid` in KiB (0 when gone).
long rssKib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return 0;
}

std::string sha256File(const fs::path& p) {
  crypto_hash_sha256_state st;
  crypto_hash_sha256_init(&st);
  std::ifstream in(p, std::ios::binary);
  std::string buf(1 << 20, '\0');
  while (in) {
    in.read(buf.data(), std::streamsize(buf.size()));
    crypto_hash_sha256_update(&st, reinterpret_cast<const unsigned char*>(buf.data()),
                              size_t(in.gcount()));
  }
  unsigned char out[crypto_hash_sha256_BYTES];
  crypto_hash_sha256_final(&st, out);
  char hex[2 * sizeof out + 1];
  for (size_t i = 0; i < sizeof out; ++i) std::snprintf(hex + 2 * i, 3, "%02x", out[i]);
  return hex;
}

// Writes `mib` MiB of pseudo-random bytes.
void writeRandom(const fs::path& p, size_t mib) {
  std::ofstream out(p, std::ios::binary);
  std::mt19937_64 rng(42);
  std::string block(1 << 20, '\0');
  for (size_t i = 0; i < mib; ++i) {
    for (size_t k = 0; k < block.size(); k += 8) {
      const uint64_t v = rng();
      std::memcpy(block.data() + k, &v, 8);
    }
    out.write(block.data(), std::streamsize(block.size()));
  }
}

class BlobHub : public ::testing::Test {
 protected:
  void SetUp() override {
    app_ = "skrobot-blob-" + std::to_string(getpid());
    cfg_ = dir_.write("cfg.json", R"({"app_name": ")" + app_ + R"(", "data_dir": "data",
        "accounts": {"dev_account": {"user": "guest", "password": "password"}}})");
  }
  void TearDown() override { ::unlink(("/tmp/" + app_).c_str()); }
  std::unique_ptr<skr::sat::test::Child> startHub(int n) {
    // In the AddressSanitizer build, freed memory waits in a quarantine (256 MB by default)
    // before it is reused: a small one lets the resident memory say what the hub holds.
    const char* asan = std::getenv("ASAN_OPTIONS");
    const std::string asan_options =
        "ASAN_OPTIONS=" +
        (asan != nullptr && *asan != '\0' ? std::string(asan) + ":" : std::string()) +
        "quarantine_size_mb=8";
    auto hub = std::make_unique<skr::sat::test::Child>(
        std::vector<std::string>{SKROBOT_BIN, "--config", cfg_.string()},
        std::vector<std::string>{asan_options},
        dir_.path() / ("hub-" + std::to_string(n) + ".log"));
    EXPECT_TRUE(hub->waitOutput("HUB-READY", 30000)) << hub->output();
    return hub;
  }
  SyncClient client() {
    sat::ConnectOptions o;
    o.address.kind = flow::Address::Kind::local;
    o.address.path = "/tmp/" + app_;
    o.timeout_ms = 30000;
    auto c = SyncClient::connect(o);
    EXPECT_TRUE(c) << c.error().message;
    return std::move(c).value();
  }

  TempDir dir_;
  std::string app_;
  fs::path cfg_;
};

TEST_F(BlobHub, ALargeRoundTripKeepsTheHubsMemoryFlat) {
  const size_t mib =
      std::getenv("BLOB_MB") ? size_t(std::atol(std::getenv("BLOB_MB"))) : BLOB_MB_DEFAULT;
  const fs::path src = dir_.path() / "src.bin", back = dir_.path() / "back.bin";
  writeRandom(src, mib);
  auto hub = startHub(0);
  SyncClient c = client();
  auto ch = c.createBlobChannel("big");
  ASSERT_TRUE(ch) << ch.error().message;
  const long base = rssKib(hub->pid());
  std::atomic<long> peak{base};
  std::atomic<bool> done{false};
  std::thread sampler([&] {
    while (!done) {
      peak = std::max(peak.load(), rssKib(hub->pid()));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  const auto t0 = std::chrono::steady_clock::now();
  auto v = c.blobPutFile(ch->id, src.string(), "run/big.bin");
  const auto t1 = std::chrono::steady_clock::now();
  auto got = c.blobGetFile(ch->id, "run/big.bin", back.string());
  const auto t2 = std::chrono::steady_clock::now();
  done = true;
  sampler.join();
  ASSERT_TRUE(v) << v.error().message;
  ASSERT_TRUE(got) << got.error().message;
  EXPECT_EQ(*got, mib << 20);
  EXPECT_EQ(sha256File(back), sha256File(src));
  const auto secs = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  const long growth_mib = (peak - base) / 1024;
  std::printf("%zu MiB: up %.0f MB/s, down %.0f MB/s; hub RSS %ld MiB at start, peak +%ld MiB\n",
              mib, double(mib << 20) / 1e6 / secs(t0, t1), double(mib << 20) / 1e6 / secs(t1, t2),
              base / 1024, growth_mib);
  EXPECT_LT(growth_mib, 48) << "the hub's memory grew with the file";
}

// The flows stay on time during a transfer: while BLOB_MB MiB go up and come back down, a
// follower of the hub's 1 kHz pulse loses few of them (the figures are printed), the pulse never
// stops for 250 ms, and a 100 Hz ping-pong through the hub is answered within 250 ms each time.
// Release build only (timing).
TEST_F(BlobHub, ATransferLeavesAKilohertzPulseAndAPingPongOnTime) {
#ifdef __SANITIZE_ADDRESS__
  GTEST_SKIP() << "timing: release build only";
#endif
  cfg_ = dir_.write("cfg.json", R"({"app_name": ")" + app_ + R"(", "data_dir": "data",
      "loop": {"fast_tick_ms": 1}, "sync": {"hub_source": "tick"},
      "accounts": {"dev_account": {"user": "guest", "password": "password"}}})");
  const size_t mib =
      std::getenv("BLOB_MB") ? size_t(std::atol(std::getenv("BLOB_MB"))) : BLOB_MB_DEFAULT;
  const fs::path src = dir_.path() / "src.bin", back = dir_.path() / "back.bin";
  writeRandom(src, mib);
  auto hub = startHub(0);

  sat::SatelliteOptions so;
  so.connection.address.kind = flow::Address::Kind::local;
  so.connection.address.path = "/tmp/" + app_;
  so.connection.client_name = "follower";
  sat::test::SatOnThread follower(so);
  follower.start();
  std::atomic<uint64_t> pulses{0}, dropped{0}, last_ns{0}, widest_ns{0};
  follower.on([&](sat::Satellite& s) {
    s.syncPulse.connect(&s, [&](const sat::SyncPulse& p) {
      ++pulses;
      dropped += p.dropped;
      // The hub's own period between two pulses (its loop late, or its ticks skipped).
      const uint64_t before = last_ns.exchange(p.source_time_ns);
      if (before != 0 && p.source_time_ns > before) {
        widest_ns = std::max<uint64_t>(widest_ns, p.source_time_ns - before);
      }
    });
    s.follow("hub.tick");
  });
  ASSERT_TRUE(sat::test::eventually([&] { return pulses > 200; })) << hub->output();

  std::atomic<bool> done{false};
  std::vector<double> pings_ms;
  std::string ping_error;
  std::thread pinger([&] {
    SyncClient p = client();
    auto next = std::chrono::steady_clock::now();
    while (!done) {
      const auto t0 = std::chrono::steady_clock::now();
      if (auto r = p.ping(); !r) {
        ping_error = r.error().message;
        return;
      }
      pings_ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      next += std::chrono::milliseconds(10);
      std::this_thread::sleep_until(next);
    }
  });
  const uint64_t pulses_before = pulses, dropped_before = dropped;
  widest_ns = 0;
  SyncClient c = client();
  auto ch = c.createBlobChannel("big");
  ASSERT_TRUE(ch) << ch.error().message;
  const auto t0 = std::chrono::steady_clock::now();
  auto up = c.blobPutFile(ch->id, src.string(), "big.bin");
  auto down = c.blobGetFile(ch->id, "big.bin", back.string());
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const uint64_t followed = pulses - pulses_before, lost = dropped - dropped_before;
  const uint64_t widest = widest_ns;
  done = true;
  pinger.join();
  ASSERT_TRUE(up) << up.error().message;
  ASSERT_TRUE(down) << down.error().message;
  EXPECT_EQ(sha256File(back), sha256File(src));
  ASSERT_TRUE(ping_error.empty()) << ping_error;
  ASSERT_FALSE(pings_ms.empty());
  const double worst = *std::max_element(pings_ms.begin(), pings_ms.end());
  std::sort(pings_ms.begin(), pings_ms.end());
  std::printf(
      "%zu MiB up and down in %.2f s: %llu pulses followed, %llu dropped, widest period %.2f ms; "
      "%zu pings, p50 %.3f ms, p99 %.3f ms, max %.3f ms\n",
      mib, secs, (unsigned long long)followed, (unsigned long long)lost, double(widest) / 1e6,
      pings_ms.size(), pings_ms[pings_ms.size() / 2], pings_ms[pings_ms.size() * 99 / 100], worst);
  // A pulse is dropped for a follower that has not said it is done with the one before (its
  // thread not scheduled within the 1 ms period, or the hub's tick late and the next on time): on
  // two cores shared with the transfer's client, the hub's I/O and store threads and the pinger,
  // 1-2% are, against 3-5% with the transfer on the hub's loop (docs/blob-channels.md, "Threads").
  EXPECT_GT(followed, 0u);
  EXPECT_LE(lost * 5, followed) << "more than 20% of the pulses dropped for the follower";
  EXPECT_LT(widest, 250'000'000u) << "the hub's pulse stopped that long during the transfer";
  EXPECT_LT(worst, 250.0) << "a ping waited that long during the transfer";
}

TEST_F(BlobHub, KillNineMidUploadLeavesTheOldVersionAndTheUploadResumes) {
  const fs::path next = dir_.path() / "next.bin";
  writeRandom(next, 48);
  uint64_t upload = 0;
  uint16_t id = 0;
  {
    auto hub = startHub(0);
    SyncClient c = client();
    auto ch = c.createBlobChannel("maps");
    ASSERT_TRUE(ch);
    id = ch->id;
    ASSERT_TRUE(c.blobPut(id, "floor/map.pgm", "the old map"));
    int acks = 0;
    auto r = c.blobPutFile(
        id, next.string(), "floor/map.pgm",
        [&](uint64_t, uint64_t) {
          if (++acks == 20) hub->signal(SIGKILL);  // about 20 of 48 MiB in
        },
        &upload);
    EXPECT_FALSE(r);
    EXPECT_EQ(hub->wait(), 128 + SIGKILL);
  }
  ASSERT_NE(upload, 0u);
  auto hub = startHub(1);
  SyncClient c = client();
  auto info = c.channel("guest.maps");
  ASSERT_TRUE(info) << info.error().message;
  EXPECT_EQ(*c.blobGet(info->id, "floor/map.pgm"), "the old map");
  auto list = c.blobList(info->id, "floor");
  ASSERT_TRUE(list);
  ASSERT_EQ(list->size(), 1u) << "a temporary file is visible";
  EXPECT_EQ((*list)[0].name, "map.pgm");
  uint64_t resumed_at = 0;
  auto v = c.blobPutFile(
      info->id, next.string(), "floor/map.pgm",
      [&](uint64_t done, uint64_t) {
        if (resumed_at == 0) resumed_at = done;
      },
      &upload);
  ASSERT_TRUE(v) << v.error().message;
  EXPECT_GT(resumed_at, uint64_t(SyncClient::kBlobChunk) * 10) << "the upload started again";
  const fs::path back = dir_.path() / "back.bin";
  ASSERT_TRUE(c.blobGetFile(info->id, "floor/map.pgm", back.string()));
  EXPECT_EQ(sha256File(back), sha256File(next));
}

}  // namespace
