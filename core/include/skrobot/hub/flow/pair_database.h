// SPDX-License-Identifier: Apache-2.0
// PairDatabases: named key -> Variant stores. Every flow, user and channel has one; named ones
// are created by satellites. DatabaseStore holds them all and keeps the persistent ones in
// <data_dir>/db: a snapshot <name>.json and an append-only log <name>.log of the changes since,
// written by a journal thread under a durability policy (docs/pair-databases.md).
//
// Not thread-safe: the hub's loop thread owns the store and every database in it.
#pragma once

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/result.h>

#include <json/value.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

// How deep a value in a database may nest: one less than the protocol's default decode limit, so
// that all(), the map of every pair, still decodes on the other side.
constexpr size_t kDatabaseMaxDepth = 31;

class PairDatabase {
 public:
  // Told of every change once it is made (the store logs those of persistent databases).
  class Listener {
   public:
    virtual ~Listener() = default;
    virtual void onSet(const PairDatabase& db, std::string_view key, const Variant& value) = 0;
    virtual void onRemove(const PairDatabase& db, std::string_view key) = 0;
    virtual void onClear(const PairDatabase& db) = 0;
  };

  explicit PairDatabase(std::string name) : name_(std::move(name)) {}

  [[nodiscard]] const std::string& name() const noexcept { return name_; }

  // nullptr when absent; valid until the key is set, removed or the database cleared.
  [[nodiscard]] const Variant* get(std::string_view key) const noexcept;
  [[nodiscard]] bool contains(std::string_view key) const noexcept;
  // Sets a pair. Keys are valid UTF-8 of at most 65535 bytes; values pass checkEncodable() with
  // max_depth kDatabaseMaxDepth. Errc::invalid_argument or Errc::limit_exceeded naming the key.
  // Setting the value a key already holds changes nothing (the version stays).
  [[nodiscard]] Result<void> set(std::string key, Variant value);
  // True when the key existed.
  bool remove(std::string_view key);
  void clear();

  [[nodiscard]] size_t size() const noexcept { return pairs_.size(); }
  [[nodiscard]] bool empty() const noexcept { return pairs_.empty(); }
  [[nodiscard]] std::vector<std::string> keys() const;  // sorted
  [[nodiscard]] const Variant::Map& pairs() const noexcept { return pairs_; }
  [[nodiscard]] Variant all() const { return Variant(pairs_); }  // a map

  // Grows by one on every change; starts at 1.
  [[nodiscard]] uint64_t version() const noexcept { return version_; }
  // Changed since markSaved() (a new database is dirty, so an empty one gets saved too).
  [[nodiscard]] bool dirty() const noexcept { return version_ != saved_version_; }
  void markSaved() noexcept { saved_version_ = version_; }
  // After loading: the version the files say, and nothing unsaved.
  void restoreVersion(uint64_t version) noexcept { version_ = saved_version_ = version; }
  // Null: nobody is told.
  void setListener(Listener* listener) noexcept { listener_ = listener; }

  // The pairs as a JSON object, values in the Variant JSON mapping.
  [[nodiscard]] Json::Value toJson() const;
  // The reverse; Errc::parse_error naming the key. The result is dirty.
  [[nodiscard]] static Result<PairDatabase> fromJson(std::string name, const Json::Value& pairs);

 private:
  void changed() noexcept { ++version_; }

  std::string name_;
  Variant::Map pairs_;
  uint64_t version_ = 1;
  uint64_t saved_version_ = 0;
  Listener* listener_ = nullptr;
};

enum class DatabaseKind {
  persistent,  // named and user databases: saved to disk
  transient,   // flow and channel databases: never written to disk
};

// 1..128 characters of [A-Za-z0-9_.-], not starting with '.': a name is also a safe file name.
// Errc::invalid_argument with the reason.
[[nodiscard]] Result<void> validateDatabaseName(std::string_view name);
// A hub's name in a linked network (docs/hub-links.md): 1-64 of A-Z a-z 0-9 _ -. It prefixes
// the names of that hub's channels and databases elsewhere ("arm/guest.camera").
[[nodiscard]] bool validHubName(std::string_view name) noexcept;

// When a change of a persistent database is on disk (docs/pair-databases.md, "Durability").
enum class Durability {
  always,    // fsynced before a synchronous write is answered; concurrent writes share fsyncs
  everysec,  // fsynced within about a second (the default)
  no,        // written at once, fsynced when the operating system likes
};
[[nodiscard]] const char* durabilityName(Durability d) noexcept;

class FileLayer;
class Journal;

class DatabaseStore final : private PairDatabase::Listener {
 public:
  // An empty data_dir persists nothing: save() and saveAll() succeed without writing. `files`:
  // the file layer (null: the operating system's; tests put a simulated disk there).
  explicit DatabaseStore(std::filesystem::path data_dir,
                         std::shared_ptr<FileLayer> files = nullptr);
  ~DatabaseStore() override;  // stops the journal (close()) if it runs
  DatabaseStore(const DatabaseStore&) = delete;
  DatabaseStore& operator=(const DatabaseStore&) = delete;

  struct LoadProblem {
    std::string file;        // the file name in <data_dir>/db
    std::string reason;      // why it was not loaded
    std::string renamed_to;  // where it went (<name>.json.corrupt-<UTC time>); empty if left
  };
  struct LoadReport {
    std::vector<std::string> loaded;  // database names
    std::vector<LoadProblem> problems;
  };

  // Reads every database in <data_dir>/db: its snapshot <name>.json, then the changes of its log
  // <name>.log that are newer. Call once, at start, before creating any. A snapshot that cannot
  // be loaded is reported (here and in the log, tag DB-CORRUPT), skipped, and renamed together
  // with its log so that nothing overwrites the evidence; the others still load. A log whose last
  // record was torn by a crash is cut before it (DB-LOG-TORN); a log damaged elsewhere is renamed
  // aside after its good records were applied (DB-LOG-CORRUPT). Leftover <name>.*.tmp-<pid> files
  // of a dead process (a crash mid-save) are removed. Fails only when the directory cannot be
  // read (Errc::io_error). Blocks on the disk: for start-up.
  [[nodiscard]] Result<LoadReport> loadAll();

  // From now on every change of a persistent database is appended to its log by the journal's
  // thread and made durable by `durability`; a log longer than `compact_bytes` (and than its
  // snapshot) is compacted into the snapshot. `post` runs a function on the loop thread. Call
  // after loadAll(); does nothing without a data directory.
  void startJournal(Durability durability, uint64_t compact_bytes,
                    std::function<void(std::function<void()>)> post);
  // Whether synchronous writes wait for the disk (the journal runs with `always`).
  [[nodiscard]] bool writesWaitForDisk() const noexcept;
  // Calls `done` on the loop thread once every change made so far is on disk (fsynced),
  // whatever the policy; at once when nothing is pending or nothing is persisted.
  void barrier(std::function<void(Result<void>)> done);
  // Snapshots what changed, waits for the journal to write and fsync everything, stops it.
  // Without a journal: saveAll(). Idempotent; blocks. Returns the first failure.
  Result<void> close();

  // Errc::already_exists if the name is taken, Errc::invalid_argument for a bad name. The
  // pointer stays valid until remove() of that name or the store's destruction.
  [[nodiscard]] Result<PairDatabase*> create(const std::string& name, DatabaseKind kind);
  // The existing database, or a new one; Errc::invalid_argument if it exists with the other kind.
  [[nodiscard]] Result<PairDatabase*> getOrCreate(const std::string& name, DatabaseKind kind);
  [[nodiscard]] PairDatabase* find(std::string_view name) noexcept;
  [[nodiscard]] const PairDatabase* find(std::string_view name) const noexcept;
  [[nodiscard]] std::optional<DatabaseKind> kind(std::string_view name) const noexcept;
  // Removes the database and its files. Errc::not_found, or Errc::io_error if the file stays
  // (the database is then still removed from memory). With a journal the files go on its thread.
  [[nodiscard]] Result<void> remove(std::string_view name);

  // Writes a persistent database's snapshot, crash-safely: a crash at any point leaves the old
  // file or the new one, never a mix. Errc::not_found, Errc::invalid_argument for a transient
  // one; with `done`, failures to write go to `done` only. Without a journal it writes now
  // (blocking on fsync) and calls `done` at once; with one the journal writes it and `done` is
  // called on the loop thread afterwards.
  [[nodiscard]] Result<void> save(std::string_view name,
                                  std::function<void(Result<void>)> done = nullptr);
  // Saves every dirty persistent database; tries them all and reports every failure in one
  // error. Without a journal it is the only way changes reach the disk.
  [[nodiscard]] Result<void> saveAll();

  [[nodiscard]] std::vector<std::string> names() const;  // sorted

  // Watchers of one database's changes, told on the loop thread right after each change (after
  // the journal was given it): `value` is the new value, or null when the key was removed; an
  // empty key with a null value: the database was cleared. A watcher may remove itself (or
  // another) from its call; it must not change the database it watches from there. A watch
  // outlives the database (it is told again when one of that name is created).
  using ChangeFn =
      std::function<void(const PairDatabase& db, std::string_view key, const Variant* value)>;
  [[nodiscard]] uint64_t watch(std::string name, ChangeFn fn);
  void unwatch(uint64_t id) noexcept;
  [[nodiscard]] const std::filesystem::path& dataDir() const noexcept { return data_dir_; }
  // <data_dir>/db, where the files go.
  [[nodiscard]] std::filesystem::path dbDir() const;

 private:
  struct Entry {
    std::unique_ptr<PairDatabase> db;
    DatabaseKind kind;
    uint64_t log_bytes = 0;       // in its log since the last snapshot
    uint64_t snapshot_bytes = 0;  // of its last snapshot
    bool compacting = false;      // a snapshot is queued
    bool needs_snapshot = false;  // its log was damaged: write a snapshot first thing
  };
  struct Pending;  // barriers waiting for the journal (loop thread)

  // PairDatabase::Listener: persistent databases' changes go to the journal.
  void onSet(const PairDatabase& db, std::string_view key, const Variant& value) override;
  void onRemove(const PairDatabase& db, std::string_view key) override;
  void onClear(const PairDatabase& db) override;
  void logged(const std::string& name, std::string records);
  void tell(const PairDatabase& db, std::string_view key, const Variant* value);
  void compact(const std::string& name, Entry& entry,
               std::function<void(Result<void>)> done = nullptr);
  // Loads one database from its snapshot and log (either may be absent).
  void loadOne(const std::string& name, bool has_snapshot, bool has_log, LoadReport& report);
  std::string setAside(const std::string& file, const std::string& stamp, std::string& reason);

  std::filesystem::path data_dir_;
  std::shared_ptr<FileLayer> files_;
  std::map<std::string, Entry, std::less<>> dbs_;
  uint64_t compact_bytes_ = 0;
  std::shared_ptr<Pending> pending_;
  std::unique_ptr<Journal> journal_;
  struct Watcher {
    std::string name;
    std::shared_ptr<ChangeFn> fn;
  };
  std::map<uint64_t, Watcher> watchers_;
  uint64_t next_watch_ = 1;
};

}  // namespace skr::flow
