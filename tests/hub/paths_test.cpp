// SPDX-License-Identifier: Apache-2.0
// Physical mode through the satellite library (docs/physical-mode.md): shared-memory and direct
// paths granted by a real hub, the relay skipped while a path works, fallback when it breaks
// (nothing delivered twice), a subscriber that asks for a kind the owner does not serve, a slow
// shared-memory reader, an owner that goes away, and a direct path over TCP to a subscriber that
// is not on the hub's machine (as far as the hub can tell: it came over TCP).
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <ctime>
#include <string>
#include <thread>
#include <vector>

#include "eventually.h"
#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

// CPU time its loop thread has used, in ms.
double loopCpuMs(SatOnThread& sat) {
  return sat.on([](Satellite&) {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
  });
}

class Paths : public SatTest {
 protected:
  void SetUp() override { startHub(); }
  // An owner of guest.frames with the given paths, and a subscriber that asks for `kinds`.
  void setUp(bool direct, bool shm, uint8_t kinds) {
    pub = satellite("pub");
    ChannelSpec spec{.name = "frames"};
    spec.physical = PhysicalOptions{.direct = direct, .shm = shm, .ring = {4, 1 << 16, 4}};
    ASSERT_TRUE(pub->on([&](Satellite& s) { return s.addChannel(spec); }));
    sub = satellite("sub");
    sub->on([&](Satellite& s) {
      s.usePaths("guest.frames", kinds);
      s.subscribe("guest.frames");
    });
    ASSERT_TRUE(eventually([&] { return pub->events.count("start:guest.frames") == 1; }));
  }
  // Publishes numbered messages until the subscriber (`sub` unless named) gets them on its path.
  bool pathWorks(SatOnThread* subscriber = nullptr) {
    int i = 0;
    SatOnThread& to = subscriber ? *subscriber : *sub;
    return eventually([&] {
      pub->on([&](Satellite& s) { (void)s.publish("frames", "warm-up " + std::to_string(i++)); });
      return to.on([](Satellite& s) { return s.pathStats().path_messages; }) > 0;
    });
  }
  void helloBeforeGrant(const std::vector<SatOnThread*>& subscribers);
  std::unique_ptr<SatOnThread> pub, sub;
};

TEST_F(Paths, SharedMemoryDeliversWithoutTheHub) {
  setUp(true, true, kPathShm);
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  EXPECT_EQ(pub->on([](Satellite& s) { return s.pathStats().served_shm; }), 1u);
  // Zero copy on both sides: filled in the slot, read in place.
  sub->events.clear();
  const uint64_t before = sub->on([](Satellite& s) { return s.pathStats().path_messages; });
  pub->on([](Satellite& s) {
    auto slot = s.beginPublish("frames");
    ASSERT_GE(slot.size(), 5u);
    std::memcpy(slot.data(), "hello", 5);
    ASSERT_TRUE(s.commitPublish("frames", 5, 42));
  });
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.frames:hello") == 1; }))
      << sub->events.dump();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(sub->events.count("data:guest.frames:hello"), 1u) << "once: not relayed as well";
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().path_messages; }), before + 1)
      << "it came by the path, not the hub";
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().torn; }), 0u);
}

// A direct path that breaks mid-stream, closed by its owner and then by its subscriber: relayed
// again with nothing lost (1.11: the owner replays what the path lost) and nothing twice, and
// asked again after a second.
TEST_F(Paths, DirectPathInOrderThenFallbackWithoutLossOrDuplicates) {
  setUp(true, false, kPathDirect | kPathShm);
  for (SatOnThread* breaker : {pub.get(), sub.get()}) {
    ASSERT_TRUE(pathWorks()) << sub->events.dump();
    EXPECT_EQ(pub->on([](Satellite& s) { return s.pathStats().served_direct; }), 1u);
    sub->events.clear();
    const uint64_t fallbacks = sub->on([](Satellite& s) { return s.pathStats().fallbacks; });
    // 300 numbered messages; the path breaks after the 110th, while they keep coming.
    for (int i = 0; i < 300; ++i) {
      pub->on([&](Satellite& s) { ASSERT_TRUE(s.publish("frames", std::to_string(i))); });
      if (i == 110) breaker->on([](Satellite& s) { s.resetPaths(); });
      if (i % 50 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.frames:299") == 1; }))
        << sub->events.count("data:");
    std::vector<int> numbers;
    for (const auto& g : sub->events.with("data:guest.frames:")) numbers.push_back(std::stoi(g));
    for (size_t k = 1; k < numbers.size(); ++k) {
      ASSERT_LT(numbers[k - 1], numbers[k]) << "in order, none twice (at " << k << ")";
    }
    EXPECT_EQ(numbers.size(), 300u)
        << "nothing lost when " << (breaker == pub.get() ? "the owner" : "the subscriber")
        << " broke the path";
    EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().fallbacks; }), fallbacks + 1);
    // Asked again after a second: the path comes back.
    ASSERT_TRUE(eventually(
        [&] {
          pub->on([](Satellite& s) { (void)s.publish("frames", "again"); });
          return pub->on([](Satellite& s) { return s.pathStats().served_direct; }) == 1;
        },
        10000));
  }
}

// Subscribers move from the relay to their direct paths while the owner publishes as fast as it
// can: from its first message on, each gets every message once, in order (1.9: the owner picks
// the point of the switch, and the marker names the last message relayed).
TEST_F(Paths, SwitchingToADirectPathLosesNothing) {
  setUp(true, false, kPathDirect);
  std::atomic<bool> stop{false};
  std::atomic<int> sent{0};
  std::thread publisher([&] {
    while (!stop) {
      const int i = sent.load();
      pub->on([&](Satellite& s) { (void)s.publish("frames", std::to_string(i)); });
      sent = i + 1;
    }
  });
  std::vector<std::unique_ptr<SatOnThread>> subs;
  subs.push_back(std::move(sub));
  for (int k = 0; k < 5; ++k) {  // each switches at another point of the stream
    subs.push_back(satellite("late" + std::to_string(k)));
    subs.back()->on([](Satellite& s) {
      s.usePaths("guest.frames", kPathDirect);
      s.subscribe("guest.frames");
    });
  }
  const bool onPaths = eventually([&] {
    return std::all_of(subs.begin(), subs.end(), [](auto& s) {
      return s->on([](Satellite& sat) { return sat.pathStats().path_messages; }) > 100;
    });
  });
  stop = true;
  publisher.join();
  ASSERT_TRUE(onPaths);
  const std::string last = std::to_string(sent - 1);
  for (size_t k = 0; k < subs.size(); ++k) {
    ASSERT_TRUE(eventually([&] { return subs[k]->events.count("data:guest.frames:" + last) > 0; }))
        << "subscriber " << k;
    std::vector<int> numbers;
    for (const auto& g : subs[k]->events.with("data:guest.frames:"))
      numbers.push_back(std::stoi(g));
    for (size_t i = 1; i < numbers.size(); ++i) {
      ASSERT_EQ(numbers[i], numbers[i - 1] + 1)
          << "subscriber " << k << ": every message once, in order (at " << i << " of "
          << numbers.size() << ")";
    }
    EXPECT_EQ(subs[k]->on([](Satellite& s) { return s.pathStats().fallbacks; }), 0u);
  }
}

// Large messages published back to back fill the owner's socket: each frame's header and
// payload go out in one call where they fit, the rest waits in the owner's queue, and the
// subscriber gets every message whole, in order.
TEST_F(Paths, LargeMessagesBehindAFullSocketArriveWholeAndInOrder) {
  setUp(true, false, kPathDirect);
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  // Message k (150-550 KB): its number in 4 bytes, then (k * 31 + i) % 251 for each byte i after.
  const auto message = [](uint32_t k) {
    std::string m((150u << 10) + (k * 104729u) % (400u << 10), '\0');
    std::memcpy(m.data(), &k, 4);
    for (size_t i = 4; i < m.size(); ++i) m[i] = static_cast<char>((k * 31 + i) % 251);
    return m;
  };
  constexpr uint32_t kMessages = 36;  // about 12 MB: under the 16 MB a subscriber may lag
  std::vector<std::string> got;
  sub->on([&](Satellite& s) {
    s.dataView.connect(&s, [&](uint16_t, std::string_view p) {
      if (p.size() >= 4 && p.substr(0, 4) != "warm") got.emplace_back(p);
    });
  });
  // The subscriber's loop is held while the owner publishes: its socket fills (8 MB at most).
  std::atomic<bool> held{false}, release{false};
  std::thread holder([&] {
    sub->on([&](Satellite&) {
      held = true;
      while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    });
  });
  while (!held) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  pub->on([&](Satellite& s) {
    for (uint32_t k = 0; k < kMessages; ++k) ASSERT_TRUE(s.publish("frames", message(k)));
  });
  release = true;
  holder.join();
  ASSERT_TRUE(eventually([&] {
    return sub->on([&](Satellite&) { return got.size(); }) >= kMessages;
  })) << sub->on([&](Satellite&) { return got.size(); });
  sub->on([&](Satellite& s) {
    s.dataView.disconnectAll();
    ASSERT_EQ(got.size(), kMessages);
    for (uint32_t k = 0; k < kMessages; ++k) {
      EXPECT_TRUE(got[k] == message(k)) << "message " << k << " (" << got[k].size() << " bytes)";
    }
  });
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().fallbacks; }), 0u);
}

// PathWait::spin: the subscriber's loop polls the ring instead of sleeping, for as long as the
// path works, and only then (its thread's CPU time tells).
TEST_F(Paths, ASpinningReaderPollsItsRingOnlyWhileThePathWorks) {
  setUp(false, true, 0);
  sub->on([](Satellite& s) { s.usePaths("guest.frames", kPathShm, PathWait::spin); });
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  const auto cpuMs = [&] { return loopCpuMs(*sub); };
  const auto busyOver300Ms = [&] {
    const double before = cpuMs();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    return cpuMs() - before;
  };
  EXPECT_GT(busyOver300Ms(), 100) << "the loop spins while the path works";
  sub->events.clear();
  for (int i = 0; i < 100; ++i) {
    pub->on([&](Satellite& s) { ASSERT_TRUE(s.publish("frames", std::to_string(i))); });
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.frames:99") == 1; }));
  std::vector<int> numbers;
  for (const auto& g : sub->events.with("data:guest.frames:")) numbers.push_back(std::stoi(g));
  for (size_t k = 1; k < numbers.size(); ++k) ASSERT_LT(numbers[k - 1], numbers[k]);
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().torn; }), 0u);
  // Unsubscribed: the path is closed and the loop sleeps again.
  sub->on([](Satellite& s) { s.unsubscribe("guest.frames"); });
  ASSERT_TRUE(eventually(
      [&] { return pub->on([](Satellite& s) { return s.pathStats().served_shm; }) == 0; }));
  EXPECT_LT(busyOver300Ms(), 50) << "no spinning without a path";
}

// A woken reader polls its ring for a moment after a message that followed another closely: a
// dense stream is then read without wake-ups (and the owner writes no eventfd); sparse messages
// are each woken, and the loop sleeps between them.
TEST_F(Paths, AWokenReaderPollsADenseStreamAndSleepsBetweenSparseMessages) {
  setUp(false, true, kPathShm);
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  const auto polled = [&] { return sub->on([](Satellite& s) { return s.pathStats().polled; }); };
  const uint64_t before = polled();
  // A stream: 2000 messages about 5 us apart, published from the owner's loop.
  pub->on([&](Satellite& s) {
    for (int i = 0; i < 2000; ++i) {
      ASSERT_TRUE(s.publish("frames", "s" + std::to_string(i)));
      const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(5);
      while (std::chrono::steady_clock::now() < until) {
      }
    }
  });
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.frames:s1999") == 1; }));
  const uint64_t in_stream = polled() - before;
  const auto st = sub->on([](Satellite& s) { return s.pathStats(); });
  EXPECT_GT(in_stream, 0u) << "a stream is read by polling; path messages " << st.path_messages
                           << ", missed " << st.missed;
  // Sparse messages: each one wakes the reader, which does not poll in between.
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const uint64_t after_stream = polled();
  for (int i = 0; i < 10; ++i) {
    pub->on([&](Satellite& s) { ASSERT_TRUE(s.publish("frames", "p" + std::to_string(i))); });
    ASSERT_TRUE(eventually(
        [&] { return sub->events.count("data:guest.frames:p" + std::to_string(i)) == 1; }));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(polled(), after_stream) << "a message long after the last one is woken";
  const auto cpuMs = [&] { return loopCpuMs(*sub); };
  const double cpu_before = cpuMs();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_LT(cpuMs() - cpu_before, 50) << "the loop sleeps between messages";
}

TEST_F(Paths, AKindTheOwnerDoesNotServeIsRelayed) {
  setUp(true, false, kPathShm);  // shared memory asked, direct offered
  for (int i = 0; i < 20; ++i) {
    pub->on([&](Satellite& s) { ASSERT_TRUE(s.publish("frames", "m" + std::to_string(i))); });
  }
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.frames:m19") == 1; }));
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().path_messages; }), 0u);
  EXPECT_EQ(pub->on([](Satellite& s) { return s.pathStats().served_direct; }), 0u);
}

TEST_F(Paths, ASlowSharedMemoryReaderGetsTheNewestAndCountsWhatItMissed) {
  setUp(false, true, kPathShm);
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  sub->on([](Satellite& s) {
    s.data.connect(&s, [](uint16_t, const std::string&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    });
  });
  sub->events.clear();
  // 200 messages at once: the owner never waits for the reader, nor fails to publish.
  for (int i = 0; i < 200; ++i) {
    pub->on([&](Satellite& s) { ASSERT_TRUE(s.publish("frames", std::to_string(i))); });
  }
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.frames:199") == 1; }))
      << sub->events.dump();
  const auto got = sub->events.with("data:guest.frames:");
  std::vector<int> numbers;
  for (const auto& g : got) numbers.push_back(std::stoi(g));
  for (size_t k = 1; k < numbers.size(); ++k) ASSERT_LT(numbers[k - 1], numbers[k]);
  EXPECT_LT(numbers.size(), 200u) << "a busy reader skips to the newest";
  const auto stats = sub->on([](Satellite& s) { return s.pathStats(); });
  EXPECT_GE(stats.missed, 200 - numbers.size()) << "what it skipped is counted";
  EXPECT_EQ(stats.torn, 0u);
  EXPECT_EQ(stats.fallbacks, 0u);
}

// What a subscriber gets on its path counts in the hub's statistics of its flow (1.10,
// PHYS_RECEIVED): messages and bytes out, the part that came on paths, and what a shared-memory
// reader skipped as drops.
TEST_F(Paths, TheHubCountsWhatEachSubscriberGetsOnItsPath) {
  setUp(true, true, kPathShm);
  auto direct = satellite("direct");
  direct->on([&](Satellite& s) {
    s.usePaths("guest.frames", kPathDirect);
    s.subscribe("guest.frames");
  });
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  ASSERT_TRUE(pathWorks(direct.get())) << direct->events.dump();
  sub->on([](Satellite& s) {
    s.data.connect(&s, [](uint16_t, const std::string&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    });
  });
  for (int i = 0; i < 200; ++i) {
    pub->on([&](Satellite& s) { ASSERT_TRUE(s.publish("frames", std::to_string(i))); });
  }
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.frames:199") == 1; }));
  ASSERT_TRUE(eventually([&] { return direct->events.count("data:guest.frames:199") == 1; }));
  struct Flow {
    uint64_t out = 0, bytes_out = 0, path = 0, path_bytes = 0, dropped = 0;
  };
  const auto flowOf = [&](const std::string& client) {
    Flow f;
    auto v = hubStats();
    if (!v) return f;
    for (const auto& fl : *v->find("flows")->asList()) {
      if (*fl.find("client") != flow::Variant(client)) continue;
      const auto n = [&](const char* k) { return uint64_t(fl.find(k)->asInt64().value_or(0)); };
      f = Flow{n("messages_out"), n("bytes_out"), n("path_messages"), n("path_bytes"),
               n("dropped")};
    }
    return f;
  };
  const auto got = [](SatOnThread& s) { return s.on([](Satellite& x) { return x.pathStats(); }); };
  // Reported once a second: wait until the hub has heard of every message each one got.
  Flow shm, dir;
  const bool reported = eventually(
      [&] {
        shm = flowOf("sub");
        dir = flowOf("direct");
        return shm.path == got(*sub).path_messages && dir.path == got(*direct).path_messages;
      },
      5000);
  ASSERT_TRUE(reported) << "shm " << shm.path << " of " << got(*sub).path_messages << ", direct "
                        << dir.path << " of " << got(*direct).path_messages;
  EXPECT_GE(dir.path, 200u);
  EXPECT_GE(dir.path_bytes, 290u) << "the 200 payloads' bytes at least";
  EXPECT_GE(dir.out, dir.path) << "messages out include the path's";
  EXPECT_GE(dir.bytes_out, dir.path_bytes);
  const auto shm_stats = got(*sub);
  EXPECT_LT(shm_stats.path_messages, 200u + 100u);
  EXPECT_GT(shm_stats.missed, 0u) << "the slow reader skipped some";
  EXPECT_EQ(shm.dropped, shm_stats.missed) << "what it skipped counts as its drops";
  EXPECT_GE(shm.out, shm.path);
}

TEST_F(Paths, AnOwnerThatGoesAwayLeavesItsReaderOnTheRelayUntilTheNextOne) {
  setUp(true, true, kPathShm);
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  const uint64_t before = sub->on([](Satellite& s) { return s.pathStats().path_messages; });
  pub.reset();  // the owner leaves while its reader holds the ring
  ASSERT_TRUE(eventually([&] { return sub->events.count("removed:guest.frames") == 1; }))
      << sub->events.dump();
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().fallbacks; }), 1u);
  // The same owner comes back: the subscription holds, and a new ring is granted.
  pub = satellite("pub");
  ChannelSpec spec{.name = "frames"};
  spec.physical = PhysicalOptions{.shm = true, .ring = {4, 1 << 16, 4}};
  ASSERT_TRUE(pub->on([&](Satellite& s) { return s.addChannel(spec); }));
  ASSERT_TRUE(eventually([&] { return pub->events.count("start:guest.frames") == 1; }));
  sub->events.clear();
  int i = 0;
  ASSERT_TRUE(eventually(
      [&] {
        pub->on([&](Satellite& s) { (void)s.publish("frames", "back " + std::to_string(i++)); });
        return sub->on([](Satellite& s) { return s.pathStats().path_messages; }) > before;
      },
      10000))
      << sub->events.dump();
  EXPECT_EQ(pub->on([](Satellite& s) { return s.pathStats().served_shm; }), 1u);
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().torn; }), 0u);
}

TEST_F(Paths, ACallbackMayResetOrLeaveThePathItIsCalledFrom) {
  // Direct: a reset in the middle of a burst of frames already read.
  setUp(true, false, kPathDirect);
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  sub->on([](Satellite& s) {
    s.data.connect(&s, [&s](uint16_t, const std::string& m) {
      if (m == "reset") s.resetPaths();
    });
  });
  pub->on([](Satellite& s) {
    for (const char* m : {"a", "reset", "b", "c"}) ASSERT_TRUE(s.publish("frames", m));
  });
  ASSERT_TRUE(eventually(
      [&] { return sub->on([](Satellite& s) { return s.pathStats(); }).fallbacks == 1; }));
  // Shared memory: leaving the channel from inside the view of the slot being read.
  auto reader = satellite("reader");
  ChannelSpec spec{.name = "ring"};
  spec.physical = PhysicalOptions{.shm = true, .ring = {4, 1 << 16, 4}};
  ASSERT_TRUE(pub->on([&](Satellite& s) { return s.addChannel(spec); }));
  reader->on([](Satellite& s) {
    s.usePaths("guest.ring", kPathShm);
    s.subscribe("guest.ring");
    s.dataView.connect(&s, [&s](uint16_t, std::string_view m) {
      if (m == "leave") s.unsubscribe("guest.ring");
    });
  });
  int i = 0;
  ASSERT_TRUE(eventually([&] {
    pub->on([&](Satellite& s) { (void)s.publish("ring", "warm-up " + std::to_string(i++)); });
    return reader->on([](Satellite& s) { return s.pathStats().path_messages; }) > 0;
  })) << reader->events.dump();
  const auto read = [](Satellite& s) { return s.pathStats().path_messages; };
  const uint64_t before = reader->on(read);
  pub->on([](Satellite& s) { ASSERT_TRUE(s.publish("ring", "leave")); });
  ASSERT_TRUE(eventually([&] { return reader->on(read) == before + 1; }));
  EXPECT_EQ(reader->events.count("data:guest.ring:leave"), 0u) << "left in the view: no copy";
  // Asking for paths again on a followed channel replaces its path (the old one is closed).
  const auto served = [](Satellite& s) { return s.pathStats().served_direct; };
  ASSERT_TRUE(eventually(
      [&] {
        pub->on([&](Satellite& s) { (void)s.publish("frames", "x" + std::to_string(i++)); });
        return pub->on(served) == 1;
      },
      10000));
  const uint64_t got = sub->on(read);
  sub->on([](Satellite& s) { s.usePaths("guest.frames", kPathDirect); });
  ASSERT_TRUE(eventually(
      [&] {
        pub->on([&](Satellite& s) { (void)s.publish("frames", "y" + std::to_string(i++)); });
        return sub->on(read) > got + 1;
      },
      10000));
  EXPECT_EQ(pub->on(served), 1u) << "the old path is gone";
  EXPECT_TRUE(sub->connected());
  EXPECT_TRUE(reader->connected());
}

// The hub tells the owner and each subscriber at once; the owner's grants wait behind 32 MB the
// hub relays to it while its loop is busy, so the subscribers' HELLOs come first. Each of
// `subscribers` asks for a direct path to guest.frames in that window.
void Paths::helloBeforeGrant(const std::vector<SatOnThread*>& subscribers) {
  pub = satellite("pub");
  ChannelSpec spec{.name = "frames"};
  spec.physical = PhysicalOptions{.direct = true};
  ASSERT_TRUE(pub->on([&](Satellite& s) { return s.addChannel(spec); }));
  auto big = satellite("big");
  ASSERT_TRUE(big->on([](Satellite& s) { return s.addChannel({.name = "big"}); }));
  pub->on([](Satellite& s) { s.subscribe("guest.big"); });
  ASSERT_TRUE(eventually([&] { return big->events.count("start:guest.big") == 1; }));
  std::thread busy([&] {
    pub->on([](Satellite&) { std::this_thread::sleep_for(std::chrono::milliseconds(1500)); });
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const std::string mb(1 << 20, 'b');
  for (int i = 0; i < 32; ++i) big->on([&](Satellite& s) { (void)s.publish("big", mb); });
  for (auto* s : subscribers) {
    s->on([](Satellite& sat) {
      sat.usePaths("guest.frames", kPathDirect);
      sat.subscribe("guest.frames");
    });
  }
  busy.join();
}

TEST_F(Paths, AHelloThatComesBeforeItsGrantWaitsForIt) {
  sub = satellite("sub");
  helloBeforeGrant({sub.get()});
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().fallbacks; }), 0u)
      << "the first HELLO was taken, not refused";
}

TEST_F(Paths, TwoHellosWaitingForTheirGrantsAreEachWokenByTheirOwn) {
  // The first grant must wake only the HELLO that carries its token, not refuse the other.
  sub = satellite("sub");
  auto sub2 = satellite("sub2");
  helloBeforeGrant({sub.get(), sub2.get()});
  ASSERT_TRUE(pathWorks()) << sub->events.dump();
  ASSERT_TRUE(pathWorks(sub2.get())) << sub2->events.dump();
  for (auto* s : {sub.get(), sub2.get()}) {
    EXPECT_EQ(s->on([](Satellite& sat) { return sat.pathStats().fallbacks; }), 0u)
        << "both first HELLOs were taken, none refused";
  }
}

class PathsOverTcp : public SatTest {
 protected:
  // alice's satellite on the hub's Unix socket, or over TCP.
  SatelliteOptions alice(const std::string& name, bool tcp) {
    SatelliteOptions o = options(name);
    if (tcp) o.connection.address = Address::parse(hub_->tcpAddress()).value();
    o.connection.user = "alice";
    o.connection.password = "s3cret-pass";
    return o;
  }
  void reachesAnotherMachine(const std::string& path_tcp, const std::string& offered);
  static std::unique_ptr<SatOnThread> started(SatelliteOptions o) {
    auto s = std::make_unique<SatOnThread>(std::move(o));
    s->start();
    return s;
  }
};

// The owner listens at `path_tcp` and the hub offers "tcp:<offered>:<port>" to the subscriber.
void PathsOverTcp::reachesAnotherMachine(const std::string& path_tcp, const std::string& offered) {
  startHub("alice");
  ASSERT_FALSE(hub_->tcpAddress().empty()) << hubLog();
  SatelliteOptions owner = alice("pub", false);
  owner.path_tcp = path_tcp;
  auto pub = started(owner);
  auto plain = started(alice("plain", false));  // offers direct paths on its Unix socket only
  ChannelSpec spec{.name = "frames"};
  spec.physical = PhysicalOptions{.direct = true, .shm = true, .ring = {4, 1 << 16, 4}};
  ASSERT_TRUE(pub->on([&](Satellite& s) { return s.addChannel(spec); }));
  spec.name = "local-only";
  ASSERT_TRUE(plain->on([&](Satellite& s) { return s.addChannel(spec); }));
  auto sub = started(alice("sub", true));
  sub->on([](Satellite& s) {
    s.usePaths("alice.frames", kPathShm | kPathDirect);
    s.subscribe("alice.frames");
    s.usePaths("alice.local-only", kPathShm | kPathDirect);
    s.subscribe("alice.local-only");
  });
  ASSERT_TRUE(eventually([&] { return plain->events.count("start:alice.local-only") == 1; }))
      << hubLog();
  int i = 0;
  ASSERT_TRUE(eventually([&] {
    pub->on([&](Satellite& s) { (void)s.publish("frames", "warm-up " + std::to_string(i++)); });
    return sub->on([](Satellite& s) { return s.pathStats().path_messages; }) > 0;
  })) << sub->events.dump()
      << hubLog();
  EXPECT_EQ(pub->on([](Satellite& s) { return s.pathStats().served_direct; }), 1u);
  EXPECT_EQ(pub->on([](Satellite& s) { return s.pathStats().served_shm; }), 0u);
  EXPECT_NE(hubLog().find("tcp:" + offered + ":"), std::string::npos) << "offered on TCP as well";
  // Every message, in order, once, by the path.
  sub->events.clear();
  const uint64_t before = sub->on([](Satellite& s) { return s.pathStats().path_messages; });
  for (int k = 0; k < 100; ++k) {
    pub->on([&](Satellite& s) { ASSERT_TRUE(s.publish("frames", std::to_string(k))); });
    plain->on([&](Satellite& s) { ASSERT_TRUE(s.publish("local-only", std::to_string(k))); });
  }
  ASSERT_TRUE(eventually([&] {
    return sub->events.count("data:alice.frames:99") == 1 &&
           sub->events.count("data:alice.local-only:99") == 1;
  })) << sub->events.dump();
  const auto got = sub->events.with("data:alice.frames:");
  ASSERT_EQ(got.size(), 100u);
  for (int k = 0; k < 100; ++k) EXPECT_EQ(got[size_t(k)], std::to_string(k));
  EXPECT_EQ(sub->on([](Satellite& s) { return s.pathStats().path_messages; }), before + 100)
      << "alice.frames came by its path; alice.local-only, which has no TCP endpoint, relayed";
  EXPECT_EQ(plain->on([](Satellite& s) { return s.pathStats().served_direct; }), 0u);
}

TEST_F(PathsOverTcp, ADirectPathReachesASubscriberOnAnotherMachine) {
  reachesAnotherMachine("127.0.0.1:0", "127.0.0.1");
}

// Whether this machine has IPv6 loopback (containers may have it disabled).
bool hasIPv6Loopback() {
  const int fd = ::socket(AF_INET6, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in6 a{};
  a.sin6_family = AF_INET6;
  a.sin6_addr = in6addr_loopback;
  const bool ok = fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  if (fd >= 0) ::close(fd);
  return ok;
}

TEST_F(PathsOverTcp, ADirectPathOverIPv6) {
  if (!hasIPv6Loopback()) GTEST_SKIP() << "no IPv6 loopback on this machine";
  reachesAnotherMachine("[::1]:0", "[::1]");
}

// A wildcard, a name, no port, a bad port, IPv6 without brackets: the owner offers its Unix
// socket only (and says why in its log).
TEST_F(PathsOverTcp, APathTcpThatIsNotAnAddressOthersReachIsNotOffered) {
  startHub("alice");
  int i = 0;
  for (const char* bad : {"0.0.0.0:0", "[::]:0", "::1:0", "robot.local:0", "127.0.0.1", "[::1]",
                          "127.0.0.1:70000", "127.0.0.1:x", "[::1]x:0"}) {
    const std::string name = "frames" + std::to_string(i++);
    SatelliteOptions o = alice("pub-" + name, false);
    o.path_tcp = bad;
    auto pub = started(o);
    ChannelSpec spec{.name = name};
    spec.physical = PhysicalOptions{.direct = true, .shm = false, .ring = {}};
    ASSERT_TRUE(eventually([&] { return pub->on([&](Satellite& s) { return s.isConnected(); }); }));
    ASSERT_TRUE(pub->on([&](Satellite& s) { return s.addChannel(spec); })) << bad;
    const std::string offer = "alice." + name + ": direct at ";
    ASSERT_TRUE(eventually([&] { return hubLog().find(offer) != std::string::npos; })) << bad;
    const std::string log = hubLog();
    const std::string line =
        log.substr(log.find(offer), log.find('\n', log.find(offer)) - log.find(offer));
    EXPECT_EQ(line.find("tcp:"), std::string::npos) << bad << ": " << line;
    EXPECT_NE(line.find("unix:"), std::string::npos) << bad << ": " << line;
  }
}

}  // namespace
}  // namespace skr::sat::test
