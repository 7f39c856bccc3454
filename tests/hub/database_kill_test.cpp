// SPDX-License-Identifier: Apache-2.0
// Durable databases under `always`, proven with the real hub and kill -9: a satellite writes with
// VAR_SET and counts the writes the hub acknowledged; the hub is killed at a random moment, twenty
// times; after every restart each acknowledged write is there and no database is lost.
// (The fsync order, which kill -9 cannot show, is tested in tests/flow/database_durability_test.)
#include "hub_process.h"  // Child
#include "temp_dir.h"
#include "test_client.h"

#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <thread>

namespace {

namespace fs = std::filesystem;
using namespace skr;
using skr::test::TempDir;
using skr::test::TestClient;

// The map of `db`'s pairs, read over the protocol.
std::optional<flow::Variant::Map> readAll(TestClient& c, const std::string& db) {
  auto sel = c.call(flow::msg::DbSelect{db});
  if (!sel || sel->kind() != flow::Code::reply_ok) return std::nullopt;
  auto all = test::as<flow::msg::ReplyValue>(c.call(flow::msg::Empty<flow::Code::var_get_all>{}));
  if (!all || all->value.asMap() == nullptr) return std::nullopt;
  return *all->value.asMap();
}

TEST(DatabaseKill, AcknowledgedWritesSurviveKillNine) {
  const int rounds = std::getenv("KILL_ROUNDS") ? std::atoi(std::getenv("KILL_ROUNDS")) : 20;
  TempDir dir;
  const std::string app = "skrobot-kill-" + std::to_string(getpid());
  const fs::path cfg = dir.write("cfg.json", R"({"app_name": ")" + app + R"(",
      "data_dir": "data", "databases": {"durability": "always", "compact_bytes": 65536},
      "accounts": {"dev_account": {"user": "guest", "password": "password"}}})");
  std::mt19937 rng(std::random_device{}());
  std::map<std::string, std::map<std::string, std::string>> acked;  // db -> key -> value
  size_t total_acked = 0;
  for (int round = 0; round < rounds; ++round) {
    const fs::path log = dir.path() / ("hub-" + std::to_string(round) + ".log");
    // Killed with SIGKILL by its destructor if a check fails midway: no hub outlives the test.
    skr::sat::test::Child hub({SKROBOT_BIN, "--config", cfg.string()}, {}, log);
    ASSERT_TRUE(hub.waitOutput("HUB-READY", 30000)) << hub.output();
    auto c = TestClient::connectUnix("/tmp/" + app);
    ASSERT_TRUE(c) << c.error().message;
    ASSERT_TRUE(c->login("guest", "password"));
    // Everything acknowledged before is here.
    for (const auto& [db, pairs] : acked) {
      auto now = readAll(*c, db);
      ASSERT_TRUE(now) << "round " << round << ": database " << db << " lost\n" << hub.output();
      for (const auto& [key, value] : pairs) {
        auto it = now->find(key);
        ASSERT_NE(it, now->end()) << "round " << round << ": acknowledged " << db << "/" << key
                                  << " lost\n"
                                  << hub.output();
        EXPECT_EQ(it->second, flow::Variant(value));
      }
    }
    if (round == 0) {
      auto created = c->call(flow::msg::DbCreate{"robot"});
      ASSERT_TRUE(created && created->kind() == flow::Code::reply_ok);
      acked["robot"];
    }
    // Write until the hub dies at a random moment.
    const int after_ms = std::uniform_int_distribution<int>(20, 250)(rng);
    std::thread killer([&hub, after_ms] {
      std::this_thread::sleep_for(std::chrono::milliseconds(after_ms));
      hub.signal(SIGKILL);
    });
    for (int i = 0;; ++i) {
      // 50 writes to the user's database, 50 to a named one, and so on.
      const std::string target = (i % 100) < 50 ? "guest" : "robot";
      if (i % 50 == 0 && !c->call(flow::msg::DbSelect{target})) break;
      const std::string key = "r" + std::to_string(round) + "-" + std::to_string(i);
      const std::string value(static_cast<size_t>(rng() % 300), char('a' + i % 26));
      auto ok = c->call(flow::msg::VarSet{key, flow::Variant(value)});
      if (!ok) break;  // the hub is gone: this write is not acknowledged
      if (ok->kind() != flow::Code::reply_ok) {
        ADD_FAILURE() << "VAR_SET refused";  // no ASSERT here: the killer thread must be joined
        break;
      }
      acked[target][key] = value;
      ++total_acked;
    }
    killer.join();
    EXPECT_EQ(hub.wait(), 128 + SIGKILL) << hub.output();
  }
  std::printf("%d kills, %zu acknowledged writes, all found after each restart\n", rounds,
              total_acked);
  EXPECT_GT(total_acked, static_cast<size_t>(rounds)) << "too few writes to prove anything";
  ::unlink(("/tmp/" + app).c_str());
}

}  // namespace
