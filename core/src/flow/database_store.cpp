// DatabaseStore: the hub's databases and their files. A save writes a temporary file, fsyncs
// it, renames it over the old one and fsyncs the directory; rename(2) is atomic, so after a crash
// the file is the old one or the new one, and a leftover temporary is never read.
#include "json_errors.h"

#include <skrobot/core/log.h>
#include <skrobot/flow/pair_database.h>

#include <json/reader.h>
#include <json/writer.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <exception>
#include <fstream>
#include <iterator>
#include <system_error>
#include <utility>

namespace skr::flow {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kLogSource = "flow.db";
constexpr int kFormat = 1;
constexpr std::string_view kJsonSuffix = ".json";
constexpr std::string_view kTmpMarker = ".json.tmp-";

class Fd {
 public:
  explicit Fd(int fd) noexcept : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  Fd(Fd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) {
      reset();
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  ~Fd() { reset(); }
  [[nodiscard]] int get() const noexcept { return fd_; }
  [[nodiscard]] bool valid() const noexcept { return fd_ >= 0; }
  // Closes now; close(2) can report a write error that fsync did not.
  int close() noexcept { return ::close(std::exchange(fd_, -1)); }

 private:
  void reset() noexcept {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int fd_;
};

Error ioError(const std::string& what, const fs::path& path, int err) {
  return makeError(Errc::io_error, what + " " + path.string() + ": " + std::strerror(err));
}

Result<void> fsyncDir(const fs::path& dir) {
  Fd fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!fd.valid()) return ioError("cannot open directory", dir, errno);
  if (::fsync(fd.get()) != 0) return ioError("cannot fsync directory", dir, errno);
  return {};
}

// Creates `dir` with mode 0700 if missing (its parents with the default mode).
Result<void> ensureDir(const fs::path& dir) {
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return {};
  if (dir.has_parent_path()) {
    fs::create_directories(dir.parent_path(), ec);
    if (ec) return ioError("cannot create directory", dir.parent_path(), ec.value());
  }
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
    return ioError("cannot create directory", dir, errno);
  }
  if (dir.has_parent_path()) return fsyncDir(dir.parent_path());
  return {};
}

Result<void> writeAll(int fd, std::string_view data, const fs::path& path) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return ioError("cannot write", path, errno);
    }
    data.remove_prefix(static_cast<size_t>(n));
  }
  return {};
}

// Replaces dir/file with `content` crash-safely (see the top of this file).
Result<void> replaceFile(const fs::path& dir, const std::string& file, std::string_view content) {
  const fs::path target = dir / file;
  const fs::path tmp = dir / (file + ".tmp-" + std::to_string(::getpid()));
  Result<void> r = [&]() -> Result<void> {
    Fd fd(::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600));
    if (!fd.valid()) return ioError("cannot create", tmp, errno);
    if (Result<void> w = writeAll(fd.get(), content, tmp); !w) return w;
    if (::fsync(fd.get()) != 0) return ioError("cannot fsync", tmp, errno);
    if (fd.close() != 0) return ioError("cannot close", tmp, errno);
    if (::rename(tmp.c_str(), target.c_str()) != 0) return ioError("cannot rename", tmp, errno);
    return {};
  }();
  if (!r) {
    ::unlink(tmp.c_str());
    return r;
  }
  return fsyncDir(dir);
}

std::string utcStamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
  return buf;
}

// Moves a file that failed to load out of the way; returns its new name, or empty.
std::string setAside(const fs::path& dir, const std::string& file, std::string& reason) {
  const std::string base = file + ".corrupt-" + utcStamp();
  std::string name = base;
  std::error_code ec;
  for (int i = 2; fs::exists(dir / name, ec) && i < 1000; ++i)
    name = base + "-" + std::to_string(i);
  if (::rename((dir / file).c_str(), (dir / name).c_str()) != 0) {
    reason += std::string("; could not rename it: ") + std::strerror(errno);
    return {};
  }
  (void)fsyncDir(dir);
  return name;
}

// A leftover temporary file whose writer is gone (it crashed, or this is a restart).
bool isStaleTmp(const std::string& file) {
  const size_t at = file.rfind(kTmpMarker);
  if (at == std::string::npos) return false;
  const std::string digits = file.substr(at + kTmpMarker.size());
  if (digits.empty() || digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return false;
  }
  const pid_t pid = static_cast<pid_t>(std::stol(digits));
  if (pid == ::getpid()) return true;  // ours, from before: this thread saves synchronously
  return ::kill(pid, 0) != 0 && errno == ESRCH;
}

Result<Json::Value> readJsonFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return ioError("cannot open", path, errno);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return ioError("cannot read", path, errno);
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
  return PairDatabase::fromJson(name, doc["pairs"]);
}

std::string documentText(const PairDatabase& db) {
  Json::Value doc(Json::objectValue);
  doc["format"] = kFormat;
  doc["name"] = db.name();
  doc["pairs"] = db.toJson();
  Json::StreamWriterBuilder builder;
  builder["indentation"] = "  ";
  builder["emitUTF8"] = true;
  return Json::writeString(builder, doc) + "\n";
}

}  // namespace

DatabaseStore::DatabaseStore(fs::path data_dir) : data_dir_(std::move(data_dir)) {}
DatabaseStore::~DatabaseStore() = default;
DatabaseStore::DatabaseStore(DatabaseStore&&) noexcept = default;
DatabaseStore& DatabaseStore::operator=(DatabaseStore&&) noexcept = default;

fs::path DatabaseStore::dbDir() const {
  return data_dir_.empty() ? fs::path() : data_dir_ / "db";
}

Result<DatabaseStore::LoadReport> DatabaseStore::loadAll() {
  LoadReport report;
  if (data_dir_.empty()) return report;
  const fs::path dir = dbDir();
  std::error_code ec;
  if (!fs::exists(dir, ec)) return report;
  std::vector<std::string> files;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file(ec)) files.push_back(it->path().filename().string());
  }
  if (ec) return ioError("cannot list", dir, ec.value());
  std::sort(files.begin(), files.end());

  for (const std::string& file : files) {
    if (!file.ends_with(kJsonSuffix)) {
      if (isStaleTmp(file) && ::unlink((dir / file).c_str()) == 0) {
        log::info(kLogSource, "DB-TMP-REMOVED",
                  "removed " + file + ", left by an interrupted save");
      }
      continue;
    }
    const std::string name = file.substr(0, file.size() - kJsonSuffix.size());
    LoadProblem problem{file, {}, {}};
    if (Result<void> valid = validateDatabaseName(name); !valid) {
      problem.reason = valid.error().message;  // not a name we would write: leave it alone
    } else if (dbs_.contains(name)) {
      problem.reason = "a database \"" + name + "\" exists already";
    } else {
      Result<Json::Value> doc = readJsonFile(dir / file);
      Result<PairDatabase> db =
          doc ? databaseFromDocument(doc.value(), name) : Result<PairDatabase>(doc.error());
      if (db) {
        db->markSaved();
        dbs_.emplace(name, Entry{std::make_unique<PairDatabase>(std::move(db).value()),
                                 DatabaseKind::persistent});
        report.loaded.push_back(name);
        continue;
      }
      problem.reason = db.error().message;
      problem.renamed_to = setAside(dir, file, problem.reason);
    }
    log::warn(kLogSource, "DB-CORRUPT",
              file + " not loaded: " + problem.reason +
                  (problem.renamed_to.empty() ? "" : "; renamed to " + problem.renamed_to));
    report.problems.push_back(std::move(problem));
  }
  return report;
}

Result<PairDatabase*> DatabaseStore::create(const std::string& name, DatabaseKind kind) {
  if (Result<void> valid = validateDatabaseName(name); !valid) return valid.error();
  if (dbs_.contains(name)) {
    return makeError(Errc::already_exists, "database \"" + name + "\" exists already");
  }
  auto db = std::make_unique<PairDatabase>(name);
  PairDatabase* p = db.get();
  dbs_.emplace(name, Entry{std::move(db), kind});
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
  const std::string file = it->first + std::string(kJsonSuffix);
  dbs_.erase(it);
  if (!on_disk) return {};
  const fs::path path = dbDir() / file;
  if (::unlink(path.c_str()) != 0) {
    if (errno == ENOENT) return {};
    return ioError("cannot remove", path, errno);
  }
  return fsyncDir(dbDir());
}

Result<void> DatabaseStore::save(std::string_view name) {
  const auto it = dbs_.find(name);
  if (it == dbs_.end()) {
    return makeError(Errc::not_found, "no database \"" + std::string(name) + "\"");
  }
  if (it->second.kind == DatabaseKind::transient) {
    return makeError(Errc::invalid_argument,
                     "database \"" + std::string(name) + "\" is transient and never saved");
  }
  if (data_dir_.empty()) return {};
  PairDatabase& db = *it->second.db;
  Result<void> r = ensureDir(data_dir_);
  if (r) r = ensureDir(dbDir());
  if (r) r = replaceFile(dbDir(), db.name() + std::string(kJsonSuffix), documentText(db));
  if (!r) {
    log::error(kLogSource, "DB-SAVE-FAILED",
               "database \"" + db.name() + "\": " + r.error().message);
    return r;
  }
  db.markSaved();
  return {};
}

Result<void> DatabaseStore::saveAll() {
  std::string failures;
  size_t failed = 0;
  for (const auto& [name, entry] : dbs_) {
    if (entry.kind != DatabaseKind::persistent || !entry.db->dirty()) continue;
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
