// SPDX-License-Identifier: Apache-2.0
// DatabaseStore: the hub's databases and their files. A persistent database is a snapshot
// <name>.json plus an append-only log <name>.log of the changes made since (database_log.h). At
// start the store reads both; afterwards its journal (database_journal.h) appends each change on
// its own thread and, when a log has grown, writes a new snapshot (temporary file, fsync, rename,
// fsync of the directory: after a crash the file is the old one or the new one) and starts the
// log afresh. Without a journal (tests, tools) save() writes snapshots directly.
#include "families/databases/database_journal.h"
#include "families/databases/database_log.h"
#include "families/databases/file_layer.h"
#include "json_errors.h"

#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/runtime/log.h>

#include <json/reader.h>
#include <json/writer.h>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <ctime>
#include <deque>
#include <exception>
#include <set>
#include <utility>

namespace skr::flow {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kLogSource = "flow.db";
constexpr int kFormat = 1;
constexpr std::string_view kJsonSuffix = ".json";
constexpr std::string_view kLogSuffix = ".log";

std::string utcStamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
  return buf;
}

// A leftover temporary file whose writer is gone (it crashed, or this is a restart).
bool isStaleTmp(const std::string& file) {
  const size_t at = file.rfind(".tmp-");
  if (at == std::string::npos) return false;
  const std::string digits = file.substr(at + 5);
  if (digits.empty() || digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return false;
  }
  const pid_t pid = static_cast<pid_t>(std::stol(digits));
  if (pid == ::getpid()) return true;  // ours, from before the journal started
  return ::kill(pid, 0) != 0 && errno == ESRCH;
}

Result<Json::Value> parseJson(const std::string& text) {
  Json::CharReaderBuilder builder;
  builder["rejectDupKeys"] = true;
  builder["failIfExtra"] = true;
  const std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value root;
  std::string errors;
  try {
    if (!reader->parse(text.data(), text.data() + text.size(), &root, &errors)) {
      return makeError(Errc::parse_error, "invalid JSON: " + jsonErrorsOneLine(errors));
    }
  } catch (const std::exception& e) {
    return makeError(Errc::parse_error, std::string("invalid JSON: ") + e.what());
  }
  return root;
}

// The database in a file's document, or why there is none.
Result<PairDatabase> databaseFromDocument(const Json::Value& doc, const std::string& name) {
  if (!doc.isObject()) return makeError(Errc::parse_error, "not a JSON object");
  const Json::Value& format = doc["format"];
  if (format.isNull()) return makeError(Errc::parse_error, "no \"format\" field");
  if (!format.isInt() || format.asInt() != kFormat) {
    Json::StreamWriterBuilder compact;
    compact["indentation"] = "";
    return makeError(Errc::parse_error, "\"format\" is " +
                                            Json::writeString(compact, format).substr(0, 40) +
                                            "; this hub reads format 1");
  }
  if (!doc["name"].isString() || doc["name"].asString() != name) {
    return makeError(Errc::parse_error, "\"name\" does not match the file name");
  }
  const Json::Value& version = doc["version"];
  if (!version.isNull() && !version.isUInt64()) {
    return makeError(Errc::parse_error, "\"version\" is not an unsigned integer");
  }
  auto db = PairDatabase::fromJson(name, doc["pairs"]);
  if (db) db->restoreVersion(version.isNull() ? 0 : version.asUInt64());
  return db;
}

}  // namespace

// Barriers waiting for the journal, and how far it got. Loop thread only; the journal's
// notifications hold it weakly, so that one arriving after the store is gone does nothing.
struct DatabaseStore::Pending {
  uint64_t last_seq = 0;     // the journal's last operation
  uint64_t durable_seq = 0;  // written and fsynced up to here
  std::deque<std::pair<uint64_t, std::function<void(Result<void>)>>> waiters;

  void durable(uint64_t seq, const Result<void>& r) {
    durable_seq = std::max(durable_seq, seq);
    while (!waiters.empty() && waiters.front().first <= seq) {
      auto done = std::move(waiters.front().second);
      waiters.pop_front();
      done(r);
    }
  }
};

DatabaseStore::DatabaseStore(fs::path data_dir, std::shared_ptr<FileLayer> files)
    : data_dir_(std::move(data_dir)),
      files_(files != nullptr ? std::move(files) : posixFiles()),
      pending_(std::make_shared<Pending>()) {}

DatabaseStore::~DatabaseStore() {
  if (journal_) journal_->stop();  // what is queued is written; nothing new is snapshotted
}

fs::path DatabaseStore::dbDir() const {
  return data_dir_.empty() ? fs::path() : data_dir_ / "db";
}

Result<DatabaseStore::LoadReport> DatabaseStore::loadAll() {
  LoadReport report;
  if (data_dir_.empty()) return report;
  const fs::path dir = dbDir();
  auto listed = files_->list(dir);
  if (!listed) return makeError(Errc::io_error, listed.error().message);
  std::vector<std::string> files = std::move(listed).value();
  std::sort(files.begin(), files.end());

  std::map<std::string, std::pair<bool, bool>> found;  // name -> (snapshot, log)
  for (const std::string& file : files) {
    const bool is_json = file.ends_with(kJsonSuffix);
    const bool is_log = file.ends_with(kLogSuffix);
    if (!is_json && !is_log) {
      if (isStaleTmp(file) && files_->remove(dir / file)) {
        log::info(kLogSource, "DB-TMP-REMOVED",
                  "removed " + file + ", left by an interrupted save");
      }
      continue;
    }
    const std::string name =
        file.substr(0, file.size() - (is_json ? kJsonSuffix.size() : kLogSuffix.size()));
    if (Result<void> valid = validateDatabaseName(name); !valid) {
      // Not a name we would write: leave it alone.
      log::warn(kLogSource, "DB-CORRUPT", file + " not loaded: " + valid.error().message);
      report.problems.push_back({file, valid.error().message, {}});
      continue;
    }
    (is_json ? found[name].first : found[name].second) = true;
  }
  for (const auto& [name, has] : found) {
    if (dbs_.contains(name)) {
      const std::string file = name + std::string(has.first ? kJsonSuffix : kLogSuffix);
      const std::string reason = "a database \"" + name + "\" exists already";
      log::warn(kLogSource, "DB-CORRUPT", file + " not loaded: " + reason);
      report.problems.push_back({file, reason, {}});
      continue;
    }
    loadOne(name, has.first, has.second, report);
  }
  return report;
}

void DatabaseStore::loadOne(const std::string& name, bool has_snapshot, bool has_log,
                            LoadReport& report) {
  const fs::path dir = dbDir();
  const std::string json_file = name + std::string(kJsonSuffix);
  const std::string log_file = name + std::string(kLogSuffix);
  const std::string stamp = utcStamp();
  PairDatabase db(name);
  db.restoreVersion(0);
  Entry entry{nullptr, DatabaseKind::persistent};

  if (has_snapshot) {
    Result<std::string> text = files_->read(dir / json_file);
    Result<PairDatabase> loaded = [&]() -> Result<PairDatabase> {
      if (!text) return text.error();
      Result<Json::Value> doc = parseJson(*text);
      if (!doc) return doc.error();
      return databaseFromDocument(*doc, name);
    }();
    if (!loaded) {
      // Kept aside with its log: the log holds only the changes after this snapshot, so
      // replaying it alone would give a database that looks whole and is not.
      LoadProblem problem{json_file, loaded.error().message, {}};
      problem.renamed_to = setAside(json_file, stamp, problem.reason);
      std::string about_log;
      if (has_log) {
        std::string why;
        const std::string moved = setAside(log_file, stamp, why);
        about_log = moved.empty() ? "; its log " + log_file + " stays" + why
                                  : "; its log, not replayed, renamed to " + moved;
      }
      log::warn(kLogSource, "DB-CORRUPT",
                json_file + " not loaded: " + problem.reason +
                    (problem.renamed_to.empty() ? "" : "; renamed to " + problem.renamed_to) +
                    about_log);
      report.problems.push_back(std::move(problem));
      return;
    }
    db = std::move(loaded).value();
    entry.snapshot_bytes = text->size();
  }

  if (has_log) {
    Result<std::string> text = files_->read(dir / log_file);
    Result<dblog::Scan> scanned =
        text ? dblog::scan(*text)
             : Result<dblog::Scan>(makeError(Errc::io_error, text.error().message));
    if (!scanned) {
      LoadProblem problem{log_file, scanned.error().message, {}};
      problem.renamed_to = setAside(log_file, stamp, problem.reason);
      log::warn(kLogSource, "DB-LOG-CORRUPT",
                log_file + " not replayed: " + problem.reason +
                    (problem.renamed_to.empty() ? "" : "; renamed to " + problem.renamed_to) +
                    "; \"" + name + "\" is loaded from its snapshot alone");
      report.problems.push_back(std::move(problem));
      entry.needs_snapshot = true;
    } else {
      bool dropped = false;
      for (dblog::Record& rec : scanned->records) {
        if (rec.op == dblog::Op::drop) {
          db = PairDatabase(name);
          db.restoreVersion(0);
          dropped = true;
          continue;
        }
        if (rec.version <= db.version()) continue;  // in the snapshot already
        dropped = false;
        switch (rec.op) {
          case dblog::Op::set:
            (void)db.set(std::move(rec.key), std::move(rec.value));
            break;
          case dblog::Op::remove:
            db.remove(rec.key);
            break;
          case dblog::Op::clear:
          case dblog::Op::drop:
            db.clear();
            break;
        }
        db.restoreVersion(rec.version);
      }
      if (dropped) {
        // Removed by a satellite just before the hub stopped: finish the removal.
        (void)files_->remove(dir / json_file);
        (void)files_->remove(dir / log_file);
        (void)files_->syncDir(dir);
        log::info(kLogSource, "DB-DROPPED",
                  "database \"" + name + "\" was being removed when the hub stopped: removed");
        return;
      }
      if (scanned->end == dblog::Scan::End::torn) {
        auto cut = files_->truncate(dir / log_file, scanned->good_bytes);
        log::warn(
            kLogSource, "DB-LOG-TORN",
            log_file + ": the last record was cut short by a crash (" + scanned->problem + "); " +
                (cut ? "the log is cut there" : "cutting the log failed: " + cut.error().message) +
                "; \"" + name + "\" has every change before it");
        if (!cut) entry.needs_snapshot = true;
      } else if (scanned->end == dblog::Scan::End::corrupt) {
        LoadProblem problem{log_file, scanned->problem, {}};
        problem.renamed_to = setAside(log_file, stamp, problem.reason);
        log::warn(kLogSource, "DB-LOG-CORRUPT",
                  log_file + " is damaged: " + problem.reason + "; the " +
                      std::to_string(scanned->records.size()) + " records before it are applied" +
                      (problem.renamed_to.empty() ? "" : "; renamed to " + problem.renamed_to));
        report.problems.push_back(std::move(problem));
        entry.needs_snapshot = true;
      }
      entry.log_bytes = scanned->good_bytes;
    }
  }
  db.restoreVersion(db.version());
  entry.db = std::make_unique<PairDatabase>(std::move(db));
  entry.db->setListener(this);
  dbs_.emplace(name, std::move(entry));
  report.loaded.push_back(name);
}

std::string DatabaseStore::setAside(const std::string& file, const std::string& stamp,
                                    std::string& reason) {
  const fs::path dir = dbDir();
  const std::string base = file + ".corrupt-" + stamp;
  std::string name = base;
  for (int i = 2; files_->exists(dir / name) && i < 1000; ++i)
    name = base + "-" + std::to_string(i);
  if (auto r = files_->rename(dir / file, dir / name); !r) {
    reason += "; could not rename it: " + r.error().message;
    return {};
  }
  (void)files_->syncDir(dir);
  return name;
}

void DatabaseStore::startJournal(Durability durability, uint64_t compact_bytes,
                                 std::function<void(std::function<void()>)> post) {
  if (data_dir_.empty() || journal_) return;
  compact_bytes_ = compact_bytes;
  std::weak_ptr<Pending> weak = pending_;
  journal_ = std::make_unique<Journal>(files_, dbDir(), durability, std::move(post),
                                       [weak](uint64_t seq, const Result<void>& r) {
                                         if (auto p = weak.lock()) p->durable(seq, r);
                                       });
  for (auto& [name, entry] : dbs_) {
    if (entry.kind == DatabaseKind::persistent && entry.needs_snapshot) compact(name, entry);
  }
}

bool DatabaseStore::writesWaitForDisk() const noexcept {
  return journal_ != nullptr && journal_->policy() == Durability::always;
}

void DatabaseStore::barrier(std::function<void(Result<void>)> done) {
  Pending& p = *pending_;
  if (!journal_ || p.durable_seq >= p.last_seq) {
    done({});
    return;
  }
  p.waiters.emplace_back(p.last_seq, std::move(done));
  journal_->requestSync();
}

Result<void> DatabaseStore::close() {
  if (!journal_) return saveAll();
  // Compacted now, the logs are empty and the next start reads snapshots only. Failures are
  // logged by the journal (DB-LOG-FAILED); the logs stay valid either way.
  for (auto& [name, entry] : dbs_) {
    if (entry.kind == DatabaseKind::persistent && (entry.log_bytes > 0 || entry.needs_snapshot)) {
      compact(name, entry);
    }
  }
  journal_->stop();
  journal_.reset();
  return {};
}

void DatabaseStore::compact(const std::string& name, Entry& entry,
                            std::function<void(Result<void>)> done) {
  entry.compacting = true;
  entry.needs_snapshot = false;
  entry.log_bytes = 0;
  std::weak_ptr<Pending> alive = pending_;
  pending_->last_seq =
      journal_->snapshot(name, entry.db->pairs(), entry.db->version(),
                         [this, alive, name, done = std::move(done)](Result<uint64_t> size) {
                           if (alive.expired()) return;
                           if (auto it = dbs_.find(name); it != dbs_.end()) {
                             it->second.compacting = false;
                             if (size) it->second.snapshot_bytes = *size;
                           }
                           if (done) done(size ? Result<void>() : Result<void>(size.error()));
                         });
}

void DatabaseStore::logged(const std::string& name, std::string records) {
  const auto it = dbs_.find(name);
  if (it == dbs_.end() || !journal_ || it->second.kind != DatabaseKind::persistent) return;
  Entry& e = it->second;
  e.log_bytes += records.size();
  pending_->last_seq = journal_->append(name, std::move(records));
  if (!e.compacting && e.log_bytes >= compact_bytes_ && e.log_bytes >= e.snapshot_bytes) {
    compact(name, e);
  }
}

void DatabaseStore::onSet(const PairDatabase& db, std::string_view key, const Variant& value) {
  if (journal_) {
    std::string record;
    dblog::appendRecord(record, db.version(), dblog::Op::set, key, &value);
    logged(db.name(), std::move(record));
  }
  tell(db, key, &value);
}

void DatabaseStore::onRemove(const PairDatabase& db, std::string_view key) {
  if (journal_) {
    std::string record;
    dblog::appendRecord(record, db.version(), dblog::Op::remove, key, nullptr);
    logged(db.name(), std::move(record));
  }
  tell(db, key, nullptr);
}

void DatabaseStore::onClear(const PairDatabase& db) {
  if (journal_) {
    std::string record;
    dblog::appendRecord(record, db.version(), dblog::Op::clear, {}, nullptr);
    logged(db.name(), std::move(record));
  }
  tell(db, {}, nullptr);
}

void DatabaseStore::tell(const PairDatabase& db, std::string_view key, const Variant* value) {
  if (watchers_.empty()) return;
  // Copied first: a watcher may unwatch (itself or another) from its call.
  std::vector<std::shared_ptr<ChangeFn>> told;
  for (const auto& [id, w] : watchers_) {
    if (w.name == db.name()) told.push_back(w.fn);
  }
  for (const auto& fn : told) (*fn)(db, key, value);
}

uint64_t DatabaseStore::watch(std::string name, ChangeFn fn) {
  const uint64_t id = next_watch_++;
  watchers_.emplace(id, Watcher{std::move(name), std::make_shared<ChangeFn>(std::move(fn))});
  return id;
}

void DatabaseStore::unwatch(uint64_t id) noexcept {
  watchers_.erase(id);
}

Result<PairDatabase*> DatabaseStore::create(const std::string& name, DatabaseKind kind) {
  // "<hub>/<name>": the database of a linked hub's channel, kept here while the link is up.
  if (const size_t slash = name.find('/'); slash != std::string::npos) {
    if (kind == DatabaseKind::persistent || !validHubName(name.substr(0, slash))) {
      return makeError(Errc::invalid_argument,
                       "database name \"" + name + "\": a \"<hub>/\" prefix names a linked hub's");
    }
    if (Result<void> valid = validateDatabaseName(std::string_view(name).substr(slash + 1));
        !valid) {
      return valid.error();
    }
  } else if (Result<void> valid = validateDatabaseName(name); !valid) {
    return valid.error();
  }
  if (dbs_.contains(name)) {
    return makeError(Errc::already_exists, "database \"" + name + "\" exists already");
  }
  auto db = std::make_unique<PairDatabase>(name);
  PairDatabase* p = db.get();
  dbs_.emplace(name, Entry{std::move(db), kind});
  p->setListener(this);  // journal (persistent ones) and watchers
  if (kind == DatabaseKind::persistent && journal_) {
    pending_->last_seq = journal_->append(name, {});  // its log: the database exists on disk
  }
  return p;
}

Result<PairDatabase*> DatabaseStore::getOrCreate(const std::string& name, DatabaseKind kind) {
  const auto it = dbs_.find(name);
  if (it == dbs_.end()) return create(name, kind);
  if (it->second.kind != kind) {
    return makeError(
        Errc::invalid_argument,
        "database \"" + name + "\" exists already as " +
            (it->second.kind == DatabaseKind::persistent ? "persistent" : "transient"));
  }
  return it->second.db.get();
}

PairDatabase* DatabaseStore::find(std::string_view name) noexcept {
  const auto it = dbs_.find(name);
  return it == dbs_.end() ? nullptr : it->second.db.get();
}

const PairDatabase* DatabaseStore::find(std::string_view name) const noexcept {
  const auto it = dbs_.find(name);
  return it == dbs_.end() ? nullptr : it->second.db.get();
}

std::optional<DatabaseKind> DatabaseStore::kind(std::string_view name) const noexcept {
  const auto it = dbs_.find(name);
  if (it == dbs_.end()) return std::nullopt;
  return it->second.kind;
}

Result<void> DatabaseStore::remove(std::string_view name) {
  const auto it = dbs_.find(name);
  if (it == dbs_.end()) {
    return makeError(Errc::not_found, "no database \"" + std::string(name) + "\"");
  }
  const bool on_disk = it->second.kind == DatabaseKind::persistent && !data_dir_.empty();
  const std::string db_name = it->first;
  const uint64_t version = it->second.db->version();
  dbs_.erase(it);
  if (!on_disk) return {};
  if (journal_) {
    std::string record;
    dblog::appendRecord(record, version + 1, dblog::Op::drop, {}, nullptr);
    pending_->last_seq = journal_->drop(db_name, std::move(record));
    return {};
  }
  for (std::string_view suffix : {kJsonSuffix, kLogSuffix}) {
    const fs::path path = dbDir() / (db_name + std::string(suffix));
    if (auto r = files_->remove(path); !r && r.error().code != Errc::not_found) return r;
  }
  return files_->syncDir(dbDir());
}

Result<void> DatabaseStore::save(std::string_view name, std::function<void(Result<void>)> done) {
  const auto it = dbs_.find(name);
  if (it == dbs_.end()) {
    return makeError(Errc::not_found, "no database \"" + std::string(name) + "\"");
  }
  if (it->second.kind == DatabaseKind::transient) {
    return makeError(Errc::invalid_argument,
                     "database \"" + std::string(name) + "\" is transient and never saved");
  }
  if (journal_) {
    compact(it->first, it->second, std::move(done));
    return {};
  }
  Result<void> r;
  if (!data_dir_.empty()) {
    PairDatabase& db = *it->second.db;
    r = files_->makeDir(dbDir());
    if (r) {
      r = replaceFile(*files_, dbDir(), db.name() + std::string(kJsonSuffix),
                      dblog::snapshotText(db.name(), db.pairs(), db.version()));
    }
    if (r) {
      db.markSaved();
    } else {
      log::error(kLogSource, "DB-SAVE-FAILED",
                 "database \"" + db.name() + "\": " + r.error().message);
    }
  }
  if (!done) return r;
  done(r);  // the result goes one way only
  return {};
}

Result<void> DatabaseStore::saveAll() {
  std::string failures;
  size_t failed = 0;
  for (auto& [name, entry] : dbs_) {
    if (entry.kind != DatabaseKind::persistent) continue;
    if (journal_) {
      if (entry.log_bytes > 0 || entry.needs_snapshot) compact(name, entry);
      continue;
    }
    if (!entry.db->dirty()) continue;
    if (Result<void> r = save(name); !r) {
      failures += (failed++ ? "; " : "") + name + ": " + r.error().message;
    }
  }
  if (failed == 0) return {};
  return makeError(Errc::io_error, std::to_string(failed) + " database(s) not saved: " + failures);
}

std::vector<std::string> DatabaseStore::names() const {
  std::vector<std::string> out;
  out.reserve(dbs_.size());
  for (const auto& [name, entry] : dbs_) out.push_back(name);
  return out;
}

}  // namespace skr::flow
