// SPDX-License-Identifier: Apache-2.0
// Durable PairDatabases: the log format, the journal's fsync order under a simulated power cut,
// and what the store does with torn and damaged files. The kill -9 test of the real hub is in
// tests/hub/database_kill_test.cpp.
#include "families/databases/database_journal.h"
#include "families/databases/database_log.h"
#include "families/databases/file_layer.h"
#include "log_capture.h"
#include "temp_dir.h"

#include <skrobot/hub/flow/pair_database.h>

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace skr;
using namespace skr::flow;

// --- a disk whose power can be cut ------------------------------------------------------------
// Every file has the data a process sees and the data that is durable (made so by sync()); every
// directory entry likewise (made durable by syncDir() of its directory). powerCut() returns the
// disk as it comes back after the cut: durable entries with durable data only. The old disk is
// dead from then on: whatever its process still does fails.
class SimDisk final : public FileLayer {
 public:
  struct Inode {
    std::string data, durable;
  };

  std::shared_ptr<SimDisk> powerCut() {
    std::lock_guard lock(m_);
    dead_ = true;
    auto after = std::make_shared<SimDisk>();
    for (const auto& [path, inode] : durable_names_) {
      auto copy = std::make_shared<Inode>(Inode{inode->durable, inode->durable});
      after->names_[path] = copy;
      after->durable_names_[path] = copy;
    }
    return after;
  }

  Result<std::unique_ptr<File>> open(const fs::path& path, bool truncate) override {
    std::lock_guard lock(m_);
    if (dead_) return dead();
    auto& inode = names_[path.string()];
    if (!inode) inode = std::make_shared<Inode>();
    if (truncate) inode->data.clear();
    return std::unique_ptr<File>(std::make_unique<SimFile>(*this, inode));
  }
  Result<std::string> read(const fs::path& path) override {
    std::lock_guard lock(m_);
    auto it = names_.find(path.string());
    if (it == names_.end()) return makeError(Errc::not_found, path.string());
    return it->second->data;
  }
  Result<void> truncate(const fs::path& path, uint64_t size) override {
    std::lock_guard lock(m_);
    if (dead_) return dead();
    auto it = names_.find(path.string());
    if (it == names_.end()) return makeError(Errc::not_found, path.string());
    it->second->data.resize(size);
    it->second->durable = it->second->data;
    return {};
  }
  Result<void> rename(const fs::path& from, const fs::path& to) override {
    std::lock_guard lock(m_);
    if (dead_) return dead();
    auto it = names_.find(from.string());
    if (it == names_.end()) return makeError(Errc::not_found, from.string());
    names_[to.string()] = it->second;
    names_.erase(from.string());
    return {};
  }
  Result<void> remove(const fs::path& path) override {
    std::lock_guard lock(m_);
    if (dead_) return dead();
    if (names_.erase(path.string()) == 0) return makeError(Errc::not_found, path.string());
    return {};
  }
  Result<void> syncDir(const fs::path& dir) override {
    std::lock_guard lock(m_);
    if (dead_) return dead();
    for (auto it = durable_names_.begin(); it != durable_names_.end();) {
      it = fs::path(it->first).parent_path() == dir ? durable_names_.erase(it) : std::next(it);
    }
    for (const auto& [path, inode] : names_) {
      if (fs::path(path).parent_path() == dir) durable_names_[path] = inode;
    }
    ++dir_syncs;
    return {};
  }
  Result<void> makeDir(const fs::path&) override { return {}; }
  Result<std::vector<std::string>> list(const fs::path& dir) override {
    std::lock_guard lock(m_);
    std::vector<std::string> out;
    for (const auto& [path, inode] : names_) {
      if (fs::path(path).parent_path() == dir) out.push_back(fs::path(path).filename().string());
    }
    return out;
  }
  bool exists(const fs::path& path) override {
    std::lock_guard lock(m_);
    return names_.contains(path.string());
  }

  int file_syncs = 0;
  int dir_syncs = 0;
  std::function<void()> before_sync;  // called by the writer before each file sync

 private:
  class SimFile final : public File {
   public:
    SimFile(SimDisk& disk, std::shared_ptr<Inode> inode) : disk_(disk), inode_(std::move(inode)) {}
    Result<void> append(std::string_view data) override {
      std::lock_guard lock(disk_.m_);
      if (disk_.dead_) return dead();
      inode_->data.append(data);
      return {};
    }
    Result<void> sync() override {
      if (disk_.before_sync) disk_.before_sync();
      std::lock_guard lock(disk_.m_);
      if (disk_.dead_) return dead();
      inode_->durable = inode_->data;
      ++disk_.file_syncs;
      return {};
    }
    uint64_t size() const override {
      std::lock_guard lock(disk_.m_);
      return inode_->data.size();
    }

   private:
    SimDisk& disk_;
    std::shared_ptr<Inode> inode_;
  };

  static Error dead() { return makeError(Errc::io_error, "the power is off"); }

  mutable std::mutex m_;
  bool dead_ = false;
  std::map<std::string, std::shared_ptr<Inode>> names_, durable_names_;
};

// The loop thread's post(): functions queued by the journal, run by the test thread.
class Posted {
 public:
  std::function<void(std::function<void()>)> poster() {
    return [this](std::function<void()> fn) {
      std::lock_guard lock(m_);
      fns_.push_back(std::move(fn));
    };
  }
  void drain() {
    std::vector<std::function<void()>> now;
    {
      std::lock_guard lock(m_);
      now.swap(fns_);
    }
    for (auto& fn : now) fn();
  }
  // Runs posted functions until `done` or about 10 s passed.
  bool until(const std::function<bool()>& done) {
    for (int i = 0; i < 10000 && !done(); ++i) {
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return done();
  }

 private:
  std::mutex m_;
  std::vector<std::function<void()>> fns_;
};

const fs::path kData = "/sim/data";
const fs::path kDbDir = "/sim/data/db";

// --- the log format --------------------------------------------------------------------------

std::string logOf(const std::vector<std::tuple<uint64_t, dblog::Op, std::string, Variant>>& recs) {
  std::string out(dblog::kHeader);
  for (const auto& [version, op, key, value] : recs) {
    dblog::appendRecord(out, version, op, key, &value);
  }
  return out;
}

TEST(DatabaseLog, RecordsRoundTrip) {
  const std::string file = logOf({{1, dblog::Op::set, "pose", Variant(Variant::List{1.5, -2})},
                                  {2, dblog::Op::remove, "pose", Variant()},
                                  {3, dblog::Op::set, "", Variant(std::string("empty key"))},
                                  {4, dblog::Op::clear, "", Variant()}});
  auto s = dblog::scan(file);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s->end, dblog::Scan::End::clean);
  EXPECT_EQ(s->good_bytes, file.size());
  ASSERT_EQ(s->records.size(), 4u);
  EXPECT_EQ(s->records[0].key, "pose");
  EXPECT_EQ(s->records[0].value, Variant(Variant::List{1.5, -2}));
  EXPECT_EQ(s->records[1].op, dblog::Op::remove);
  EXPECT_EQ(s->records[2].value, Variant(std::string("empty key")));
  EXPECT_EQ(s->records[3].version, 4u);
  EXPECT_EQ(dblog::crc32c("123456789"), 0xE3069283u);  // the standard check value
}

TEST(DatabaseLog, TornTailAndCorruptMiddleAreToldApart) {
  const std::string two =
      logOf({{1, dblog::Op::set, "a", Variant(1)}, {2, dblog::Op::set, "b", Variant(2)}});
  const std::string one = logOf({{1, dblog::Op::set, "a", Variant(1)}});
  for (size_t cut = one.size() + 1; cut < two.size(); ++cut) {
    auto s = dblog::scan(std::string_view(two).substr(0, cut));
    ASSERT_TRUE(s);
    EXPECT_EQ(s->end, dblog::Scan::End::torn) << "cut at " << cut;
    EXPECT_EQ(s->good_bytes, one.size());
    EXPECT_EQ(s->records.size(), 1u);
  }
  // A crash that left zeros where the last record should be is torn too.
  auto zeros = dblog::scan(one + std::string(40, '\0'));
  ASSERT_TRUE(zeros);
  EXPECT_EQ(zeros->end, dblog::Scan::End::torn);
  // A flipped byte in the first record, with a good one after it: corrupt.
  std::string flipped = two;
  flipped[dblog::kHeader.size() + 12] ^= 0x40;
  auto bad = dblog::scan(flipped);
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->end, dblog::Scan::End::corrupt);
  EXPECT_TRUE(bad->records.empty());
  EXPECT_NE(bad->problem.find("checksum"), std::string::npos) << bad->problem;
  EXPECT_FALSE(dblog::scan("not a log at all"));
  EXPECT_EQ(dblog::scan("SKRDB")->end, dblog::Scan::End::torn);  // header cut short
}

// --- acknowledged writes survive a power cut at any moment ---------------------------------

struct Acked {
  std::vector<std::pair<std::string, std::string>> written;  // (database, key), in order
  size_t acked = 0;  // written[0, acked) were acknowledged durable
};

// Writes under `always` with a barrier after each write, cutting the power at a random moment;
// after each cut every acknowledged write must be there. With compact_bytes small, snapshots
// and log restarts happen all along.
void powerCuts(int rounds, uint32_t seed) {
  std::mt19937 rng(seed);
  auto disk = std::make_shared<SimDisk>();
  Acked state;
  std::map<std::string, std::string> values;  // key -> value written (keys are unique)
  for (int round = 0; round < rounds; ++round) {
    Posted posted;
    std::shared_ptr<SimDisk> after;
    {
      DatabaseStore store(kData, disk);
      auto loaded = store.loadAll();
      ASSERT_TRUE(loaded) << loaded.error().message;
      ASSERT_TRUE(loaded->problems.empty())
          << loaded->problems[0].file << ": " << loaded->problems[0].reason;
      for (size_t i = 0; i < state.acked; ++i) {
        const auto& [db, key] = state.written[i];
        const PairDatabase* d = store.find(db);
        ASSERT_NE(d, nullptr) << "round " << round << ": database " << db << " lost";
        const Variant* v = d->get(key);
        ASSERT_NE(v, nullptr) << "round " << round << ": acknowledged " << db << "/" << key
                              << " lost (" << i << " of " << state.acked << " acknowledged)";
        EXPECT_EQ(*v, Variant(values[key]));
      }
      // What was written but not acknowledged may or may not be there; nothing else may be.
      state.written.resize(state.acked);
      for (const std::string& name : store.names()) {
        for (const std::string& key : store.find(name)->keys()) {
          ASSERT_TRUE(values.contains(key)) << "a key nobody wrote: " << key;
        }
      }
      store.startJournal(Durability::always, 4096, posted.poster());
      for (const char* name : {"arm", "head", "legs"}) {
        if (store.find(name) == nullptr) {
          ASSERT_TRUE(store.create(name, DatabaseKind::persistent));
        }
      }
      const int writes = std::uniform_int_distribution<int>(20, 300)(rng);
      const int cut_at = std::uniform_int_distribution<int>(0, writes)(rng);
      for (int i = 0; i < writes; ++i) {
        if (i == cut_at / 2) {
          // Some writes surely acknowledged each round, however the threads are scheduled.
          const size_t want = state.written.size();
          ASSERT_TRUE(posted.until([&] { return state.acked >= want; }));
        }
        if (i == cut_at) after = disk->powerCut();  // the writer may be anywhere in a batch
        const std::string db = std::vector<std::string>{"arm", "head", "legs"}[rng() % 3];
        const std::string key = "r" + std::to_string(round) + "w" + std::to_string(i);
        // Values of up to 1 KiB: the logs pass 4 KiB and get compacted.
        values[key] = std::string(rng() % 1024, char('a' + rng() % 26));
        ASSERT_TRUE(store.find(db)->set(key, Variant(values[key])));
        state.written.emplace_back(db, key);
        const size_t upto = state.written.size();
        store.barrier([&state, upto](Result<void> r) {
          if (r) state.acked = std::max(state.acked, upto);
        });
        if (rng() % 4 == 0) posted.drain();
      }
      if (!after) after = disk->powerCut();
      posted.drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      posted.drain();
    }  // the store goes like a killed process: its journal's writes fail from the cut on
    posted.drain();
    disk = after;
  }
  EXPECT_GT(state.acked, 0u) << "nothing was ever acknowledged: the test tests nothing";
}

TEST(DatabaseDurability, AcknowledgedWritesSurvivePowerCuts) {
  test::LogCapture quiet;  // DB-LOG-FAILED after each cut
  powerCuts(25, 1234);
}

TEST(DatabaseDurability, SnapshotIsSyncedBeforeItReplacesTheOldOneAndBeforeTheLogRestarts) {
  // A database with a log, compacted, then a cut right after the compaction's done callback:
  // the data must come back from the snapshot.
  auto disk = std::make_shared<SimDisk>();
  Posted posted;
  std::shared_ptr<SimDisk> after;
  {
    DatabaseStore store(kData, disk);
    ASSERT_TRUE(store.loadAll());
    store.startJournal(Durability::no, 1 << 20, posted.poster());
    PairDatabase* db = store.create("robot", DatabaseKind::persistent).value();
    for (int i = 0; i < 50; ++i) ASSERT_TRUE(db->set("k" + std::to_string(i), Variant(i)));
    bool saved = false;
    ASSERT_TRUE(store.save("robot", [&saved](Result<void> r) { saved = r.ok(); }));
    ASSERT_TRUE(posted.until([&] { return saved; }));
    after = disk->powerCut();  // under `no` the log was never synced: only the snapshot counts
  }
  DatabaseStore reloaded(kData, after);
  auto report = reloaded.loadAll();
  ASSERT_TRUE(report);
  const PairDatabase* db = reloaded.find("robot");
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(db->size(), 50u);
  EXPECT_EQ(*db->get("k49"), Variant(49));
}

TEST(DatabaseDurability, ARemovedDatabaseIsGoneOrWholeNeverHalf) {
  for (const bool wait : {true, false}) {
    auto disk = std::make_shared<SimDisk>();
    Posted posted;
    std::shared_ptr<SimDisk> after;
    {
      DatabaseStore store(kData, disk);
      ASSERT_TRUE(store.loadAll());
      store.startJournal(Durability::always, 1 << 20, posted.poster());
      PairDatabase* db = store.create("tmp", DatabaseKind::persistent).value();
      ASSERT_TRUE(db->set("a", Variant(1)));
      bool synced = false;
      store.barrier([&synced](Result<void> r) { synced = r.ok(); });
      ASSERT_TRUE(posted.until([&] { return synced; }));
      ASSERT_TRUE(store.save("tmp"));  // a snapshot and a log, both to be removed
      ASSERT_TRUE(store.find("tmp")->set("b", Variant(2)));
      ASSERT_TRUE(store.remove("tmp"));
      if (wait) {
        bool gone = false;
        store.barrier([&gone](Result<void> r) { gone = r.ok(); });
        ASSERT_TRUE(posted.until([&] { return gone; }));
      }
      after = disk->powerCut();
    }
    test::LogCapture logs;
    DatabaseStore reloaded(kData, after);
    ASSERT_TRUE(reloaded.loadAll());
    const PairDatabase* db = reloaded.find("tmp");
    if (wait) {
      EXPECT_EQ(db, nullptr) << "an acknowledged removal came back";
    }
    if (db != nullptr) {
      EXPECT_EQ(db->size(), db->contains("b") ? 2u : 1u) << "half a database";
    }
  }
}

// --- torn and damaged files on a real disk ---------------------------------------------------

// A store on `dir` that wrote `pairs` to its log (not compacted: the store is dropped, not closed).
void writeThroughLog(const fs::path& dir, const std::string& name,
                     const std::vector<std::pair<std::string, int>>& pairs) {
  Posted posted;
  DatabaseStore store(dir);
  ASSERT_TRUE(store.loadAll());
  store.startJournal(Durability::always, 1 << 20, posted.poster());
  auto db = store.getOrCreate(name, DatabaseKind::persistent);
  ASSERT_TRUE(db);
  for (const auto& [k, v] : pairs) ASSERT_TRUE((*db)->set(k, Variant(v)));
  bool synced = false;
  store.barrier([&synced](Result<void> r) { synced = r.ok(); });
  ASSERT_TRUE(posted.until([&] { return synced; }));
}

std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(DatabaseDurability, ATornLastRecordIsCutAwayWithALogLine) {
  test::TempDir tmp;
  writeThroughLog(tmp.path(), "robot", {{"a", 1}, {"b", 2}});
  const fs::path log = tmp.path() / "db" / "robot.log";
  const auto good_size = fs::file_size(log);
  {
    std::string half;
    dblog::appendRecord(half, 3, dblog::Op::set, "c", nullptr);
    std::ofstream(log, std::ios::app | std::ios::binary) << half.substr(0, half.size() - 3);
  }
  test::LogCapture logs;
  DatabaseStore store(tmp.path());
  auto report = store.loadAll();
  ASSERT_TRUE(report);
  EXPECT_TRUE(report->problems.empty());
  ASSERT_NE(store.find("robot"), nullptr);
  EXPECT_EQ(*store.find("robot")->get("b"), Variant(2));
  EXPECT_FALSE(store.find("robot")->contains("c"));
  EXPECT_TRUE(logs.sawTag("DB-LOG-TORN"));
  EXPECT_EQ(fs::file_size(log), good_size) << "the torn record is cut away";
}

TEST(DatabaseDurability, ADamagedLogIsSetAsideAfterItsGoodRecords) {
  test::TempDir tmp;
  writeThroughLog(tmp.path(), "robot", {{"a", 1}, {"b", 2}, {"c", 3}});
  const fs::path log = tmp.path() / "db" / "robot.log";
  std::string bytes = slurp(log);
  uint32_t first_len = 0;
  std::memcpy(&first_len, bytes.data() + dblog::kHeader.size(), 4);
  const size_t second = dblog::kHeader.size() + 8 + first_len;
  bytes[second + 8] ^= 0x01;  // the second record's version: its checksum no longer matches
  std::ofstream(log, std::ios::trunc | std::ios::binary) << bytes;
  test::LogCapture logs;
  DatabaseStore store(tmp.path());
  auto report = store.loadAll();
  ASSERT_TRUE(report);
  ASSERT_EQ(report->problems.size(), 1u);
  EXPECT_EQ(report->problems[0].file, "robot.log");
  EXPECT_TRUE(fs::exists(tmp.path() / "db" / report->problems[0].renamed_to));
  const PairDatabase* db = store.find("robot");
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(*db->get("a"), Variant(1));
  EXPECT_FALSE(db->contains("b"));
  EXPECT_TRUE(logs.sawTag("DB-LOG-CORRUPT"));
}

TEST(DatabaseDurability, ACorruptSnapshotIsKeptAsideWithItsLogAndOthersLoad) {
  test::TempDir tmp;
  writeThroughLog(tmp.path(), "robot", {{"a", 1}});
  writeThroughLog(tmp.path(), "other", {{"x", 7}});
  std::ofstream(tmp.path() / "db" / "robot.json") << "{\"format\": 1, \"name\": \"rob";
  test::LogCapture logs;
  DatabaseStore store(tmp.path());
  auto report = store.loadAll();
  ASSERT_TRUE(report);
  ASSERT_EQ(report->problems.size(), 1u);
  EXPECT_EQ(report->problems[0].file, "robot.json");
  EXPECT_EQ(store.find("robot"), nullptr);
  ASSERT_NE(store.find("other"), nullptr);
  EXPECT_EQ(*store.find("other")->get("x"), Variant(7));
  int aside = 0;
  for (const auto& e : fs::directory_iterator(tmp.path() / "db")) {
    const std::string f = e.path().filename().string();
    if (f.starts_with("robot.json.corrupt-") || f.starts_with("robot.log.corrupt-")) ++aside;
  }
  EXPECT_EQ(aside, 2) << "the snapshot and its log, both kept";
  EXPECT_FALSE(fs::exists(tmp.path() / "db" / "robot.log"));
  EXPECT_TRUE(logs.sawTag("DB-CORRUPT"));
}

TEST(DatabaseDurability, ConcurrentWritesShareFsyncs) {
  // The first fsync is held until 2000 more writes, each with its barrier, are queued: they
  // must all be made durable by the next one or two fsyncs, not by one each.
  auto disk = std::make_shared<SimDisk>();
  std::mutex m;
  std::condition_variable cv;
  bool release = false;
  std::atomic<int> held{0};
  disk->before_sync = [&] {
    if (held++ != 0) return;
    std::unique_lock lock(m);
    cv.wait(lock, [&] { return release; });
  };
  Posted posted;
  DatabaseStore store(kData, disk);
  ASSERT_TRUE(store.loadAll());
  store.startJournal(Durability::always, 1 << 30, posted.poster());
  PairDatabase* db = store.create("robot", DatabaseKind::persistent).value();
  int acked = 0;
  ASSERT_TRUE(db->set("first", Variant(0)));
  store.barrier([&acked](Result<void> r) { acked += r.ok(); });
  for (int i = 0; i < 1000 && held == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_EQ(held, 1) << "the writer never reached its first fsync";
  for (int i = 0; i < 2000; ++i) {
    ASSERT_TRUE(db->set("k" + std::to_string(i), Variant(i)));
    store.barrier([&acked](Result<void> r) { acked += r.ok(); });
  }
  {
    std::lock_guard lock(m);
    release = true;
  }
  cv.notify_all();
  ASSERT_TRUE(posted.until([&] { return acked == 2001; }));
  EXPECT_LE(disk->file_syncs, 3) << "2000 writes queued during one fsync share the next";
}

}  // namespace
