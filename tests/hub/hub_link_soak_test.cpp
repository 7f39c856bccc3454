// SPDX-License-Identifier: Apache-2.0
// Hub links under churn: three hubs in a chain (ay -> bee -> sea), publishers on sea and bee,
// subscribers on ay, while bee (the middle hub) is restarted again and again. Publishers put a
// sequence number in each payload; each subscriber checks, per channel, that nothing arrives
// twice or out of order, and that data flows again after every restart without any satellite
// doing anything. Short by default; LINK_SOAK_SATELLITES (default 12), LINK_SOAK_CHANNELS
// (default 48) and LINK_SOAK_CUTS (default 3) for the issue's full run (50, 200, 10).
#include <atomic>
#include <map>
#include <mutex>

#include "named_hub.h"

namespace skr::sat::test {
namespace {

int envInt(const char* name, int def) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::atoi(v) : def;
}

// What one subscriber saw of each channel: the last sequence number, and its faults.
struct Seen {
  std::mutex m;
  std::map<std::string, long> last;
  std::map<std::string, long> count;
  std::vector<std::string> faults;
};

TEST(HubLinkSoak, ChannelsOfTwoHubsSurviveTheMiddleHubRestartingWithoutDuplicatesOrDisorder) {
  const int satellites = std::max(4, envInt("LINK_SOAK_SATELLITES", 12));
  const int channels = std::max(satellites, envInt("LINK_SOAK_CHANNELS", 48));
  const int cuts = envInt("LINK_SOAK_CUTS", 3);
  NamedHub sea("sea");
  NamedHub bee("bee");
  NamedHub ay("ay");
  ASSERT_TRUE(sea.start());
  ASSERT_TRUE(bee.link(sea).start());
  ASSERT_TRUE(ay.link(bee).start());
  const auto logs = [&] {
    return "--- ay\n" + ay.hub->log() + "--- bee\n" + bee.hub->log() + "--- sea\n" + sea.hub->log();
  };

  // Half the satellites publish (on sea, and one in four on bee), half subscribe on ay.
  const int publishers = satellites / 2;
  std::vector<std::unique_ptr<SatOnThread>> pubs, subs;
  std::vector<std::vector<std::string>> names(publishers);  // short names per publisher
  std::vector<std::string> remote;                          // as ay sees them
  for (int p = 0; p < publishers; ++p) {
    const bool on_bee = p % 4 == 3;
    auto s = std::make_unique<SatOnThread>((on_bee ? bee : sea).options("pub" + std::to_string(p)));
    s->start();
    for (int c = p; c < channels; c += publishers) {
      const std::string n = "c" + std::to_string(c);
      ASSERT_TRUE(s->on([&](Satellite& sat) { return sat.addChannel({.name = n}); }));
      names[p].push_back(n);
      remote.push_back(std::string(on_bee ? "bee" : "sea") + "/guest." + n);
    }
    pubs.push_back(std::move(s));
  }
  std::vector<std::unique_ptr<Seen>> seen;
  const size_t nsubs = size_t(satellites - publishers);
  // Subscriber i takes every channel whose index falls to it, and a few more.
  const auto wanted = [&](size_t i, size_t k) { return k % nsubs == i || k % 7 == i % 7; };
  for (size_t i = 0; i < nsubs; ++i) {
    auto s = std::make_unique<SatOnThread>(ay.options("sub" + std::to_string(i)));
    // (subscribed before it starts: kept by name until the channel appears)
    seen.push_back(std::make_unique<Seen>());
    Seen* mine = seen.back().get();
    s->on([&, mine](Satellite& sat) {
      sat.data.connect(&sat, [&sat, mine](uint16_t id, const std::string& payload) {
        const ChannelInfo* c = sat.channel(id);
        const std::string name = c != nullptr ? c->name : "#" + std::to_string(id);
        const long seq = std::atol(payload.c_str());
        std::lock_guard lock(mine->m);
        auto [it, fresh] = mine->last.emplace(name, seq);
        if (!fresh && seq <= it->second) {
          mine->faults.push_back(name + ": " + std::to_string(seq) + " after " +
                                 std::to_string(it->second));
        }
        it->second = seq;
        ++mine->count[name];
      });
      for (size_t k = 0; k < remote.size(); ++k) {
        if (wanted(i, k)) sat.subscribe(remote[k]);
      }
    });
    s->start();
    subs.push_back(std::move(s));
  }

  // Publishers: every 20 ms, the next sequence number on each of their channels.
  std::atomic<bool> stop{false};
  std::atomic<long> seq{0};
  std::thread publisher([&] {
    while (!stop) {
      const long n = ++seq;
      for (int p = 0; p < publishers; ++p) {
        pubs[size_t(p)]->on([&](Satellite& sat) {
          for (const std::string& name : names[size_t(p)]) {
            if (sat.hasSubscribers(name)) (void)sat.publish(name, std::to_string(n));
          }
        });
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  // Joined however the test ends (a failed ASSERT returns early).
  struct Joiner {
    std::atomic<bool>& stop;
    std::thread& thread;
    ~Joiner() {
      stop = true;
      if (thread.joinable()) thread.join();
    }
  } joiner{stop, publisher};
  const auto counts = [&] {
    long total = 0;
    for (auto& s : seen) {
      std::lock_guard lock(s->m);
      for (const auto& [name, n] : s->count) total += n;
    }
    return total;
  };
  // Every subscription gets data (now, and again after each restart).
  std::string missing;
  const auto allFlowing = [&](long since_seq) {
    for (size_t i = 0; i < subs.size(); ++i) {
      missing = "sub" + std::to_string(i) + " not subscribed to all";
      const bool ok = subs[i]->on([&](Satellite& sat) {
        for (size_t k = 0; k < remote.size(); ++k) {
          if (wanted(i, k) && !sat.isSubscribed(remote[k])) return false;
        }
        return true;
      });
      if (!ok) return false;
      std::lock_guard lock(seen[i]->m);
      for (size_t k = 0; k < remote.size(); ++k) {
        if (!wanted(i, k)) continue;
        auto it = seen[i]->last.find(remote[k]);
        missing = "sub" + std::to_string(i) + ": nothing new on " + remote[k];
        if (it == seen[i]->last.end() || it->second <= since_seq) return false;
      }
    }
    return true;
  };
  ASSERT_TRUE(eventually([&] { return allFlowing(0); }, 30000)) << missing << "\n" << logs();
  for (int cut = 0; cut < cuts; ++cut) {
    ASSERT_EQ(bee.hub->stop(), 0) << logs();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    ASSERT_TRUE(bee.start()) << logs();
    const long restarted_at = seq;
    ASSERT_TRUE(eventually([&] { return allFlowing(restarted_at); }, 30000))
        << "cut " << cut << ": " << missing << "\n"
        << logs();
  }
  stop = true;
  publisher.join();
  for (auto& s : seen) {
    std::lock_guard lock(s->m);
    EXPECT_TRUE(s->faults.empty()) << s->faults.size() << " faults, first: " << s->faults[0];
    for (const auto& [name, n] : s->count) EXPECT_EQ(name.find('#'), std::string::npos) << name;
  }
  EXPECT_GT(counts(), 0);
  std::printf("%ld messages received by %zu subscribers on %zu channels, %d restarts of bee\n",
              counts(), nsubs, remote.size(), cuts);
  subs.clear();
  pubs.clear();
}

}  // namespace
}  // namespace skr::sat::test
