// SPDX-License-Identifier: Apache-2.0
// PairDatabase and DatabaseStore: pairs, names, persistence across store instances, crash
// leftovers and corrupt files.
#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/runtime/log.h>
#include "log_capture.h"
#include "temp_dir.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace skr::flow {
namespace {

namespace fs = std::filesystem;
using skr::test::TempDir;
using Map = Variant::Map;
using List = Variant::List;
using Bytes = Variant::Bytes;

#define EXPECT_HAS(haystack, needle) \
  EXPECT_NE((haystack).find(needle), std::string::npos) << (haystack)

std::string readFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeFile(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

std::vector<std::string> filesIn(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

// Log lines "<tag> <message>" while alive.
using skr::test::LogCapture;

PairDatabase* mustCreate(DatabaseStore& store, const std::string& name, DatabaseKind kind) {
  Result<PairDatabase*> db = store.create(name, kind);
  EXPECT_TRUE(db.ok()) << db.error().message;
  return db.ok() ? db.value() : nullptr;
}

// --- PairDatabase ----------------------------------------------------------------------------

TEST(PairDatabaseTest, GetSetRemove) {
  PairDatabase db("robot");
  EXPECT_EQ(db.name(), "robot");
  EXPECT_TRUE(db.empty());
  EXPECT_EQ(db.get("a"), nullptr);
  ASSERT_TRUE(db.set("b", 2).ok());
  ASSERT_TRUE(db.set("a", "one").ok());
  ASSERT_NE(db.get("a"), nullptr);
  EXPECT_EQ(*db.get("a"), Variant("one"));
  EXPECT_TRUE(db.contains("b"));
  EXPECT_EQ(db.size(), 2u);
  EXPECT_EQ(db.keys(), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(db.all(), Variant(Map{{"a", "one"}, {"b", 2}}));
  ASSERT_TRUE(db.set("a", List{1, 2}).ok());  // replaces, any type
  EXPECT_EQ(*db.get("a"), Variant(List{1, 2}));
  EXPECT_TRUE(db.remove("a"));
  EXPECT_FALSE(db.remove("a"));
  EXPECT_FALSE(db.contains("a"));
  db.clear();
  EXPECT_EQ(db.size(), 0u);
}

TEST(PairDatabaseTest, VersionCountsChanges) {
  PairDatabase db("v");
  EXPECT_TRUE(db.dirty());  // new: to be saved even when empty
  const uint64_t v0 = db.version();
  db.markSaved();
  EXPECT_FALSE(db.dirty());
  ASSERT_TRUE(db.set("k", 1).ok());
  EXPECT_EQ(db.version(), v0 + 1);
  EXPECT_TRUE(db.dirty());
  db.markSaved();
  ASSERT_TRUE(db.set("k", 1).ok());  // same value: no change
  EXPECT_FALSE(db.remove("zz"));
  EXPECT_EQ(db.version(), v0 + 1);
  EXPECT_FALSE(db.dirty());
  ASSERT_TRUE(db.set("k", 1u).ok());  // another type is another value
  EXPECT_TRUE(db.remove("k"));
  db.clear();  // already empty: no change
  EXPECT_EQ(db.version(), v0 + 3);
}

TEST(PairDatabaseTest, RefusesWhatCouldNotBeSentOrSaved) {
  PairDatabase db("d");
  Result<void> r = db.set("\xFF", 1);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::invalid_argument);
  EXPECT_HAS(r.error().message, "key is not valid UTF-8");
  EXPECT_FALSE(db.set(std::string(65536, 'k'), 1).ok());
  EXPECT_TRUE(db.set(std::string(65535, 'k'), 1).ok());
  r = db.set("s", List{"ok", "\xC0\x80"});
  ASSERT_FALSE(r.ok());
  EXPECT_HAS(r.error().message, "database \"d\" key \"s\": $[1]: string is not valid UTF-8");
  Variant deep = List{};
  for (size_t i = 1; i < kDatabaseMaxDepth; ++i) deep = List{std::move(deep)};
  EXPECT_TRUE(db.set("deep", deep).ok());
  r = db.set("deeper", List{deep});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::limit_exceeded);
  EXPECT_FALSE(db.contains("deeper"));
}

TEST(PairDatabaseTest, JsonRoundTrip) {
  PairDatabase db("j");
  ASSERT_TRUE(db.set("bytes", Bytes("\x00\xFF", 2)).ok());
  ASSERT_TRUE(db.set("$base64", "not bytes: a key of the pairs, not a value").ok());
  ASSERT_TRUE(db.set("nested", Map{{"$map", List{1.5, nullptr}}}).ok());
  const Json::Value json = db.toJson();
  EXPECT_EQ(json["bytes"]["$base64"].asString(), "AP8=");
  Result<PairDatabase> back = PairDatabase::fromJson("j", json);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->all(), db.all());
  Json::Value bad(Json::objectValue);
  bad["x"]["$base64"] = "%%%%";
  Result<PairDatabase> err = PairDatabase::fromJson("j", bad);
  ASSERT_FALSE(err.ok());
  EXPECT_HAS(err.error().message, "pairs key \"x\": $: \"$base64\" holds invalid base64");
  EXPECT_FALSE(PairDatabase::fromJson("j", Json::Value(3)).ok());
}

TEST(DatabaseNameTest, Validation) {
  for (const char* ok : {"a", "robot", "alice.camera", "flow-12", "A_b.c-9", "a.", "a..b"}) {
    EXPECT_TRUE(validateDatabaseName(ok).ok()) << ok;
  }
  EXPECT_TRUE(validateDatabaseName(std::string(128, 'x')).ok());
  const std::pair<std::string, const char*> bad[] = {
      {"", "empty"},
      {std::string(129, 'x'), "129 characters exceeds 128"},
      {".hidden", "must not start with '.'"},
      {"..", "must not start with '.'"},
      {"a/b", "character 0x2f at position 1"},
      {"a b", "character 0x20"},
      {"caf\xC3\xA9", "character 0xc3 at position 3"},
      {std::string("a\0b", 3), "character 0x00"},
  };
  for (const auto& [name, why] : bad) {
    Result<void> r = validateDatabaseName(name);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_EQ(r.error().code, Errc::invalid_argument);
    EXPECT_HAS(r.error().message, why);
  }
}

// --- DatabaseStore in memory -----------------------------------------------------------------

TEST(DatabaseStoreTest, CreateFindRemove) {
  DatabaseStore store({});
  PairDatabase* db = mustCreate(store, "named", DatabaseKind::persistent);
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(store.find("named"), db);
  EXPECT_EQ(store.find("other"), nullptr);
  EXPECT_EQ(store.kind("named"), DatabaseKind::persistent);
  Result<PairDatabase*> again = store.create("named", DatabaseKind::persistent);
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code, Errc::already_exists);
  Result<PairDatabase*> bad = store.create("../etc", DatabaseKind::persistent);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, Errc::invalid_argument);

  Result<PairDatabase*> same = store.getOrCreate("named", DatabaseKind::persistent);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same.value(), db);
  Result<PairDatabase*> other_kind = store.getOrCreate("named", DatabaseKind::transient);
  ASSERT_FALSE(other_kind.ok());
  EXPECT_HAS(other_kind.error().message, "exists already as persistent");
  Result<PairDatabase*> flow = store.getOrCreate("flow-7", DatabaseKind::transient);
  ASSERT_TRUE(flow.ok());
  EXPECT_EQ(store.names(), (std::vector<std::string>{"flow-7", "named"}));

  EXPECT_TRUE(store.remove("named").ok());
  EXPECT_EQ(store.find("named"), nullptr);
  Result<void> gone = store.remove("named");
  ASSERT_FALSE(gone.ok());
  EXPECT_EQ(gone.error().code, Errc::not_found);
  EXPECT_EQ(store.save("named").error().code, Errc::not_found);
}

TEST(DatabaseStoreTest, NoDataDirPersistsNothing) {
  DatabaseStore store({});
  ASSERT_TRUE(mustCreate(store, "n", DatabaseKind::persistent)->set("k", 1).ok());
  EXPECT_TRUE(store.save("n").ok());
  EXPECT_TRUE(store.saveAll().ok());
  Result<DatabaseStore::LoadReport> report = store.loadAll();
  ASSERT_TRUE(report.ok());
  EXPECT_TRUE(report->loaded.empty());
}

// --- persistence -----------------------------------------------------------------------------

TEST(DatabaseStoreTest, PersistsAcrossInstances) {
  TempDir tmp;
  const fs::path data = tmp.path() / "data";  // created by the first save
  const Variant nested = Map{{"list", List{1, "two", Bytes("\x01\x02", 2), List{}}}, {"m", Map{}}};
  {
    DatabaseStore store(data);
    Result<DatabaseStore::LoadReport> empty = store.loadAll();  // no directory yet: fine
    ASSERT_TRUE(empty.ok());
    PairDatabase* db = mustCreate(store, "config", DatabaseKind::persistent);
    ASSERT_TRUE(db->set("name",
                        "R\xC3\xB6"
                        "bi")
                    .ok());
    ASSERT_TRUE(db->set("imin", std::numeric_limits<int64_t>::min()).ok());
    ASSERT_TRUE(db->set("umax", std::numeric_limits<uint64_t>::max()).ok());
    ASSERT_TRUE(db->set("pi", 3.14159).ok());
    ASSERT_TRUE(db->set("three", 3.0).ok());
    ASSERT_TRUE(db->set("on", true).ok());
    ASSERT_TRUE(db->set("nothing", nullptr).ok());
    ASSERT_TRUE(db->set("nested", nested).ok());
    ASSERT_TRUE(db->set("nan", std::nan("")).ok());
    mustCreate(store, "empty", DatabaseKind::persistent);
    ASSERT_TRUE(store.saveAll().ok());
    EXPECT_FALSE(db->dirty());
  }
  struct stat st {};
  ASSERT_EQ(::stat(data.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);
  ASSERT_EQ(::stat((data / "db").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);
  ASSERT_EQ(::stat((data / "db" / "config.json").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(filesIn(data / "db"), (std::vector<std::string>{"config.json", "empty.json"}));
  const std::string text = readFile(data / "db" / "config.json");
  EXPECT_HAS(text, "\"format\" : 1");
  EXPECT_HAS(text, "\"name\" : \"config\"");
  EXPECT_HAS(text, "\"$base64\" : \"AQI=\"");
  EXPECT_HAS(text,
             "R\xC3\xB6"
             "bi");  // UTF-8 as is

  DatabaseStore store(data);
  Result<DatabaseStore::LoadReport> report = store.loadAll();
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->loaded, (std::vector<std::string>{"config", "empty"}));
  EXPECT_TRUE(report->problems.empty());
  EXPECT_EQ(store.kind("config"), DatabaseKind::persistent);
  const PairDatabase* db = store.find("config");
  ASSERT_NE(db, nullptr);
  EXPECT_FALSE(db->dirty());
  EXPECT_EQ(*db->get("name"), Variant("R\xC3\xB6"
                                      "bi"));
  EXPECT_EQ(*db->get("imin"), Variant(std::numeric_limits<int64_t>::min()));
  EXPECT_EQ(*db->get("umax"), Variant(std::numeric_limits<uint64_t>::max()));
  EXPECT_EQ(*db->get("pi"), Variant(3.14159));
  EXPECT_EQ(*db->get("three"), Variant(3.0));
  EXPECT_EQ(*db->get("on"), Variant(true));
  EXPECT_EQ(*db->get("nothing"), Variant());
  EXPECT_EQ(*db->get("nested"), nested);
  EXPECT_EQ(*db->get("nan"), Variant());  // JSON has no NaN: saved as null
  ASSERT_NE(store.find("empty"), nullptr);
  EXPECT_TRUE(store.find("empty")->empty());
}

TEST(DatabaseStoreTest, SaveOnlyWhatChanged) {
  TempDir tmp;
  DatabaseStore store(tmp.path());
  PairDatabase* db = mustCreate(store, "a", DatabaseKind::persistent);
  ASSERT_TRUE(store.saveAll().ok());
  const fs::path file = tmp.path() / "db" / "a.json";
  ASSERT_TRUE(fs::exists(file));
  fs::remove(file);
  ASSERT_TRUE(store.saveAll().ok());  // clean: not rewritten
  EXPECT_FALSE(fs::exists(file));
  ASSERT_TRUE(db->set("k", 1).ok());
  ASSERT_TRUE(store.saveAll().ok());
  EXPECT_TRUE(fs::exists(file));
  ASSERT_TRUE(db->set("k", 2).ok());
  ASSERT_TRUE(store.save("a").ok());  // overwrites
  DatabaseStore reloaded(tmp.path());
  ASSERT_TRUE(reloaded.loadAll().ok());
  EXPECT_EQ(*reloaded.find("a")->get("k"), Variant(2));
  EXPECT_EQ(filesIn(tmp.path() / "db"), (std::vector<std::string>{"a.json"}));  // no temporaries
}

TEST(DatabaseStoreTest, TransientNeverSaved) {
  TempDir tmp;
  DatabaseStore store(tmp.path());
  PairDatabase* flow = mustCreate(store, "flow-1", DatabaseKind::transient);
  ASSERT_TRUE(flow->set("k", 1).ok());
  ASSERT_TRUE(mustCreate(store, "kept", DatabaseKind::persistent)->set("k", 1).ok());
  ASSERT_TRUE(store.saveAll().ok());
  Result<void> r = store.save("flow-1");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::invalid_argument);
  EXPECT_EQ(filesIn(tmp.path() / "db"), (std::vector<std::string>{"kept.json"}));
  EXPECT_TRUE(store.remove("flow-1").ok());
}

TEST(DatabaseStoreTest, RemoveDeletesTheFile) {
  TempDir tmp;
  {
    DatabaseStore store(tmp.path());
    mustCreate(store, "gone", DatabaseKind::persistent);
    mustCreate(store, "stays", DatabaseKind::persistent);
    ASSERT_TRUE(store.saveAll().ok());
    ASSERT_TRUE(store.remove("gone").ok());
    EXPECT_EQ(filesIn(tmp.path() / "db"), (std::vector<std::string>{"stays.json"}));
    mustCreate(store, "never-saved", DatabaseKind::persistent);
    EXPECT_TRUE(store.remove("never-saved").ok());  // no file: fine
  }
  DatabaseStore store(tmp.path());
  ASSERT_TRUE(store.loadAll().ok());
  EXPECT_EQ(store.names(), (std::vector<std::string>{"stays"}));
}

TEST(DatabaseStoreTest, LeftoverTemporaryFromACrashIsIgnored) {
  TempDir tmp;
  {
    DatabaseStore store(tmp.path());
    ASSERT_TRUE(mustCreate(store, "cfg", DatabaseKind::persistent)->set("k", "old").ok());
    ASSERT_TRUE(store.saveAll().ok());
  }
  const fs::path dir = tmp.path() / "db";
  // A save that crashed before its rename: half a file, by a process that is gone...
  writeFile(dir / "cfg.json.tmp-999999999", R"({"format": 1, "name": "cfg", "pairs": {"k": "ne)");
  // ...and one by a process that is still alive (pid 1), which must not be touched.
  writeFile(dir / "cfg.json.tmp-1", "{");
  LogCapture logs;
  DatabaseStore store(tmp.path());
  Result<DatabaseStore::LoadReport> report = store.loadAll();
  ASSERT_TRUE(report.ok());
  EXPECT_EQ(report->loaded, (std::vector<std::string>{"cfg"}));
  EXPECT_TRUE(report->problems.empty());
  EXPECT_EQ(*store.find("cfg")->get("k"), Variant("old"));
  EXPECT_EQ(filesIn(dir), (std::vector<std::string>{"cfg.json", "cfg.json.tmp-1"}));
  bool logged = false;
  for (const std::string& line : logs.lines()) {
    logged |= line.starts_with("DB-TMP-REMOVED removed cfg.json.tmp-999999999");
  }
  EXPECT_TRUE(logged);
}

TEST(DatabaseStoreTest, CorruptFilesAreReportedRenamedAndSkipped) {
  TempDir tmp;
  const fs::path dir = tmp.path() / "db";
  fs::create_directories(dir);
  writeFile(dir / "good.json", R"({"format": 1, "name": "good", "pairs": {"k": 1}})");
  writeFile(dir / "broken.json", R"({"format": 1, "name": "broken", "pairs": {"k": )");
  writeFile(dir / "future.json", R"({"format": 2, "name": "future", "pairs": {}})");
  writeFile(dir / "moved.json", R"({"format": 1, "name": "other", "pairs": {}})");
  writeFile(dir / "badvalue.json", R"({"format": 1, "name": "badvalue",
                                      "pairs": {"b": {"$base64": "***"}}})");
  writeFile(dir / "list.json", "[]");
  writeFile(dir / "bad name.json", "{}");
  writeFile(dir / "notes.txt", "not a database");
  LogCapture logs;
  DatabaseStore store(tmp.path());
  Result<DatabaseStore::LoadReport> report = store.loadAll();
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->loaded, (std::vector<std::string>{"good"}));
  EXPECT_EQ(store.names(), (std::vector<std::string>{"good"}));

  std::map<std::string, DatabaseStore::LoadProblem> problems;
  for (const auto& p : report->problems) problems[p.file] = p;
  ASSERT_EQ(problems.size(), 6u);
  EXPECT_HAS(problems["broken.json"].reason, "invalid JSON: Line 1");
  EXPECT_HAS(problems["future.json"].reason, "\"format\" is 2; this hub reads format 1");
  EXPECT_HAS(problems["moved.json"].reason, "\"name\" does not match the file name");
  EXPECT_HAS(problems["badvalue.json"].reason, "pairs key \"b\": $: \"$base64\" holds invalid");
  EXPECT_HAS(problems["list.json"].reason, "not a JSON object");
  EXPECT_HAS(problems["bad name.json"].reason, "character 0x20");
  EXPECT_TRUE(problems["bad name.json"].renamed_to.empty());  // never ours to overwrite

  for (const char* name : {"broken", "future", "moved", "badvalue", "list"}) {
    const DatabaseStore::LoadProblem& p = problems[std::string(name) + ".json"];
    EXPECT_TRUE(p.renamed_to.starts_with(std::string(name) + ".json.corrupt-")) << p.renamed_to;
    EXPECT_TRUE(fs::exists(dir / p.renamed_to)) << p.renamed_to;
    EXPECT_FALSE(fs::exists(dir / (std::string(name) + ".json")));
  }
  size_t logged = 0;
  for (const std::string& line : logs.lines()) logged += line.starts_with("DB-CORRUPT ") ? 1 : 0;
  EXPECT_EQ(logged, 6u);

  // A new database of that name saves without destroying the evidence.
  const std::string evidence = readFile(dir / problems["broken.json"].renamed_to);
  mustCreate(store, "broken", DatabaseKind::persistent);
  ASSERT_TRUE(store.saveAll().ok());
  EXPECT_EQ(readFile(dir / problems["broken.json"].renamed_to), evidence);
  EXPECT_TRUE(fs::exists(dir / "broken.json"));
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
}

TEST(DatabaseStoreTest, SaveFailureIsReported) {
  TempDir tmp;
  writeFile(tmp.path() / "file", "x");
  DatabaseStore store(tmp.path() / "file" / "data");  // a regular file where a directory goes
  mustCreate(store, "a", DatabaseKind::persistent);
  mustCreate(store, "b", DatabaseKind::persistent);
  Result<void> one = store.save("a");
  ASSERT_FALSE(one.ok());
  EXPECT_EQ(one.error().code, Errc::io_error);
  EXPECT_TRUE(store.find("a")->dirty());
  Result<void> all = store.saveAll();
  ASSERT_FALSE(all.ok());
  EXPECT_HAS(all.error().message, "2 database(s) not saved: a: ");
  EXPECT_HAS(all.error().message, "; b: ");
}

}  // namespace
}  // namespace skr::flow
