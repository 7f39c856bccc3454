// PairDatabases: named key -> Variant stores. Every flow, user and channel has one; named ones
// are created by satellites. DatabaseStore holds them all and saves the persistent ones to
// <data_dir>/db/<name>.json, crash-safely (docs/pair-databases.md).
//
// Not thread-safe: the hub's loop thread owns the store and every database in it.
#pragma once

#include <skrobot/core/result.h>
#include <skrobot/flow/variant.h>

#include <json/value.h>

#include <cstdint>
#include <filesystem>
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
};

enum class DatabaseKind {
  persistent,  // named and user databases: saved to disk
  transient,   // flow and channel databases: never written to disk
};

// 1..128 characters of [A-Za-z0-9_.-], not starting with '.': a name is also a safe file name.
// Errc::invalid_argument with the reason.
[[nodiscard]] Result<void> validateDatabaseName(std::string_view name);

class DatabaseStore {
 public:
  // An empty data_dir persists nothing: save() and saveAll() succeed without writing.
  explicit DatabaseStore(std::filesystem::path data_dir);
  ~DatabaseStore();
  DatabaseStore(const DatabaseStore&) = delete;
  DatabaseStore& operator=(const DatabaseStore&) = delete;
  DatabaseStore(DatabaseStore&&) noexcept;
  DatabaseStore& operator=(DatabaseStore&&) noexcept;

  struct LoadProblem {
    std::string file;        // the file name in <data_dir>/db
    std::string reason;      // why it was not loaded
    std::string renamed_to;  // where it went (<name>.json.corrupt-<UTC time>); empty if left
  };
  struct LoadReport {
    std::vector<std::string> loaded;  // database names
    std::vector<LoadProblem> problems;
  };

  // Reads every <data_dir>/db/<name>.json, as persistent databases. Call once, at start, before
  // creating any. A file that cannot be loaded is reported (here and in the log, tag DB-CORRUPT),
  // skipped, and renamed so that the next save does not overwrite the evidence; the others still
  // load. Leftover <name>.json.tmp-<pid> files of a dead process (a crash mid-save) are removed.
  // Fails only when the directory cannot be read (Errc::io_error).
  [[nodiscard]] Result<LoadReport> loadAll();

  // Errc::already_exists if the name is taken, Errc::invalid_argument for a bad name. The
  // pointer stays valid until remove() of that name or the store's destruction.
  [[nodiscard]] Result<PairDatabase*> create(const std::string& name, DatabaseKind kind);
  // The existing database, or a new one; Errc::invalid_argument if it exists with the other kind.
  [[nodiscard]] Result<PairDatabase*> getOrCreate(const std::string& name, DatabaseKind kind);
  [[nodiscard]] PairDatabase* find(std::string_view name) noexcept;
  [[nodiscard]] const PairDatabase* find(std::string_view name) const noexcept;
  [[nodiscard]] std::optional<DatabaseKind> kind(std::string_view name) const noexcept;
  // Removes the database and its file. Errc::not_found, or Errc::io_error if the file stays
  // (the database is then still removed from memory).
  [[nodiscard]] Result<void> remove(std::string_view name);

  // Writes a persistent database to disk, crash-safely: a crash at any point leaves the old file
  // or the new one, never a mix. Errc::not_found, Errc::invalid_argument for a transient one,
  // Errc::io_error. Blocks on fsync: milliseconds on a slow disk.
  [[nodiscard]] Result<void> save(std::string_view name);
  // Saves every dirty persistent database; tries them all and reports every failure in one
  // error. The hub calls it periodically and at shutdown; the destructor does not save.
  [[nodiscard]] Result<void> saveAll();

  [[nodiscard]] std::vector<std::string> names() const;  // sorted
  [[nodiscard]] const std::filesystem::path& dataDir() const noexcept { return data_dir_; }
  // <data_dir>/db, where the files go.
  [[nodiscard]] std::filesystem::path dbDir() const;

 private:
  struct Entry {
    std::unique_ptr<PairDatabase> db;
    DatabaseKind kind;
  };
  std::filesystem::path data_dir_;
  std::map<std::string, Entry, std::less<>> dbs_;
};

}  // namespace skr::flow
