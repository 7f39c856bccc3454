// SPDX-License-Identifier: Apache-2.0
#include "families/blobs/blob_store.h"

#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/log.h>

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <random>

namespace skr::flow {

using blob::Fd;
using blob::fsError;

namespace {

constexpr const char* kLog = "blob";
constexpr size_t kWriteBackFrom = 256 * 1024;  // BlobIo::write starts write-back from this size

uint64_t versionOf(const struct stat& st) {
  const uint64_t mtime = uint64_t(st.st_mtim.tv_sec) * 1000000000u + uint64_t(st.st_mtim.tv_nsec);
  uint64_t h = uint64_t(st.st_ino) * 0x9E3779B97F4A7C15ull;
  h ^= (mtime + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full;
  h ^= uint64_t(st.st_dev) * 0x165667B19E3779F9ull + uint64_t(st.st_size);
  return h != 0 ? h : 1;
}

int64_t mtimeNs(const struct stat& st) {
  return int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

std::string hex16(uint64_t v) {
  char b[17];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(v));
  return b;
}

// Reads a small file beneath `dir`; empty on any failure.
std::string readSmall(int dir, const char* name) {
  Fd fd(::openat(dir, name, O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
  if (!fd.valid()) return {};
  std::string s(4096, '\0');
  const ssize_t n = ::read(fd.get(), s.data(), s.size());
  s.resize(n > 0 ? size_t(n) : 0);
  return s;
}

Result<void> writeSmall(BlobIo& io, int dir, const std::string& name, const std::string& text) {
  Fd fd(::openat(dir, name.c_str(), O_CREAT | O_TRUNC | O_WRONLY | O_NOFOLLOW | O_CLOEXEC, 0600));
  if (!fd.valid()) return fsError(errno, name);
  if (auto w = io.write(fd.get(), text, 0); !w) return w;
  return io.sync(fd.get());
}

// Visits the entries of the directory `dir` (not "." and ".."), with lstat-like results.
template <class F>
Result<void> forEntries(int dir, F&& f) {
  const int copy = ::openat(dir, ".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (copy < 0) return fsError(errno, "a directory");
  DIR* d = ::fdopendir(copy);
  if (d == nullptr) {
    ::close(copy);
    return fsError(errno, "a directory");
  }
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (name == "." || name == "..") continue;
    struct stat st {};
    if (::fstatat(dir, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) continue;
    f(name, st);
  }
  ::closedir(d);
  return {};
}

// Bytes and regular files beneath `dir` (symlinks and other kinds are not counted).
void measure(int dir, uint64_t& bytes, uint64_t& files, int depth = 0) {
  if (depth > int(blob::kMaxDepth)) return;
  (void)forEntries(dir, [&](const std::string& name, const struct stat& st) {
    if (S_ISREG(st.st_mode)) {
      bytes += uint64_t(st.st_size);
      ++files;
    } else if (S_ISDIR(st.st_mode)) {
      Fd sub(::openat(dir, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
      if (sub.valid()) measure(sub.get(), bytes, files, depth + 1);
    }
  });
}

// Removes `name` beneath `dir` and everything in it, never following a symlink.
void removeTree(int dir, const std::string& name, int depth = 0) {
  if (::unlinkat(dir, name.c_str(), 0) == 0 || errno == ENOENT) return;
  Fd sub(::openat(dir, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
  if (sub.valid() && depth < 64) {
    std::vector<std::string> names;
    (void)forEntries(sub.get(),
                     [&](const std::string& n, const struct stat&) { names.push_back(n); });
    for (const auto& n : names) removeTree(sub.get(), n, depth + 1);
  }
  ::unlinkat(dir, name.c_str(), AT_REMOVEDIR);
}

Result<Fd> openOrMakeDir(int parent, const std::string& name) {
  if (::mkdirat(parent, name.c_str(), 0700) != 0 && errno != EEXIST) return fsError(errno, name);
  Fd fd(::openat(parent, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
  if (!fd.valid()) return fsError(errno, name);
  return fd;
}

Error quotaError(const std::string& who, const char* what, uint64_t would, uint64_t limit) {
  return makeError(Errc::limit_exceeded, "blob quota: " + who + " would hold " +
                                             std::to_string(would) + " " + what +
                                             ", its limit is " + std::to_string(limit));
}

}  // namespace

// --- BlobIo: the real system calls ---------------------------------------------------------------

Result<void> BlobIo::write(int fd, std::string_view data, uint64_t offset) {
  const uint64_t start = offset;
  const size_t bytes = data.size();
  while (!data.empty()) {
    const ssize_t n = ::pwrite(fd, data.data(), data.size(), off_t(offset));
    if (n < 0) {
      if (errno == EINTR) continue;
      return fsError(errno, "writing a file");
    }
    data.remove_prefix(size_t(n));
    offset += uint64_t(n);
  }
  // Start writing these pages back now (without waiting), so that the sync that ends an upload
  // finds little left to write: the disk works while the rest arrives. Advice only.
  if (bytes >= kWriteBackFrom) {
    (void)::sync_file_range(fd, off_t(start), off_t(bytes), SYNC_FILE_RANGE_WRITE);
  }
  return {};
}

Result<void> BlobIo::sync(int fd) {
  if (::fsync(fd) != 0) return fsError(errno, "fsync");
  return {};
}

Result<void> BlobIo::rename(int from_dir, const std::string& from, int to_dir,
                            const std::string& to) {
  if (::renameat(from_dir, from.c_str(), to_dir, to.c_str()) != 0) return fsError(errno, to);
  return {};
}

Result<void> BlobIo::syncDir(int dir) {
  if (::fsync(dir) != 0) return fsError(errno, "fsync of a directory");
  return {};
}

// --- the worker's state --------------------------------------------------------------------------

struct BlobStore::Channel {
  std::string owner;
  Fd dir, files, uploads;
  uint64_t bytes = 0, count = 0;                    // stored
  uint64_t reserved_bytes = 0, reserved_count = 0;  // uploads under way
};

struct BlobStore::Upload {
  std::string channel, path;
  uint64_t total = 0, received = 0;
  Fd fd;
  uint32_t writer = 0;  // the connection that started or last resumed it: its chunks only
};

struct BlobStore::Reading {
  std::string channel, path;
  uint64_t version = 0, size = 0;
  Fd fd;
};

struct BlobStore::State {
  Fd root;
  std::map<std::string, Channel> channels;
  std::map<uint64_t, Upload> uploads;
  std::map<uint32_t, Reading> reads;
  std::mt19937_64 rng{std::random_device{}()};

  Result<Channel*> channel(const std::string& name) {
    auto it = channels.find(name);
    if (it == channels.end()) return makeError(Errc::not_found, "no blob store for " + name);
    return &it->second;
  }

  // What `owner`'s channels hold together, uploads under way included.
  std::pair<uint64_t, uint64_t> usageOf(const std::string& owner) const {
    uint64_t bytes = 0, count = 0;
    for (const auto& [name, ch] : channels) {
      if (ch.owner != owner) continue;
      bytes += ch.bytes + ch.reserved_bytes;
      count += ch.count + ch.reserved_count;
    }
    return {bytes, count};
  }
};

namespace {

struct Located {
  Fd parent;
  std::string name;
};

// The parent directory of `path` in `files` and its last component; `make` creates missing
// directories on the way (each opened without following symlinks).
Result<Located> locate(int files, const std::string& path, bool make) {
  auto parts = blob::splitPath(path, false);
  if (!parts) return parts.error();
  const size_t n = parts->size();
  auto parent = blob::openDirBeneath(files, *parts, n - 1);
  if (!parent && parent.error().code == Errc::not_found && make) {
    Fd dir(::fcntl(files, F_DUPFD_CLOEXEC, 0));
    for (size_t i = 0; i + 1 < n; ++i) {
      auto next = openOrMakeDir(dir.get(), (*parts)[i]);
      if (!next) return next.error();
      dir = std::move(next).value();
    }
    return Located{std::move(dir), (*parts)[n - 1]};
  }
  if (!parent) return parent.error();
  return Located{std::move(parent).value(), (*parts)[n - 1]};
}

}  // namespace

// --- BlobStore -----------------------------------------------------------------------------------

BlobStore::BlobStore(std::filesystem::path root, BlobQuota per_channel, Post post,
                     std::shared_ptr<BlobIo> io)
    : root_(std::move(root)),
      per_channel_(per_channel),
      post_(std::move(post)),
      io_(std::move(io)),
      state_(std::make_unique<State>()) {}

BlobStore::~BlobStore() {
  worker_.stop();  // what was asked runs first, while the state is still here
}

Result<std::vector<BlobStore::Stored>> BlobStore::open() {
  std::error_code ec;
  std::filesystem::create_directories(root_, ec);
  if (ec)
    return makeError(Errc::io_error, "blob stores in " + root_.string() + ": " + ec.message());
  State& s = *state_;
  s.root = Fd(::open(root_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!s.root.valid()) return fsError(errno, root_.string());
  std::vector<std::string> names;
  (void)forEntries(s.root.get(), [&](const std::string& name, const struct stat& st) {
    if (S_ISDIR(st.st_mode)) names.push_back(name);
  });
  std::vector<Stored> stored;
  for (const auto& name : names) {
    if (name.front() == '#') {  // a store whose removal was cut short
      removeTree(s.root.get(), name);
      continue;
    }
    Channel ch;
    ch.dir = Fd(::openat(s.root.get(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW));
    if (!ch.dir.valid()) continue;
    ch.owner = readSmall(ch.dir.get(), "owner");
    while (!ch.owner.empty() && std::isspace(static_cast<unsigned char>(ch.owner.back()))) {
      ch.owner.pop_back();  // a newline left by a hand edit
    }
    auto files = openOrMakeDir(ch.dir.get(), "files");
    auto uploads = openOrMakeDir(ch.dir.get(), "uploads");
    if (ch.owner.empty() || !files || !uploads) {
      log::warn(kLog, "BLOB-STORE-SKIPPED",
                root_.string() + "/" + name + ": no owner file or no files/ directory");
      continue;
    }
    ch.files = std::move(files).value();
    ch.uploads = std::move(uploads).value();
    measure(ch.files.get(), ch.bytes, ch.count);
    // Uploads under way when the hub stopped: <id>.meta says what each <id>.part becomes.
    std::vector<std::string> metas;
    (void)forEntries(ch.uploads.get(),
                     [&](const std::string& n, const struct stat&) { metas.push_back(n); });
    for (const auto& meta : metas) {
      if (meta.size() != 21 || meta.substr(16) != ".meta") {
        if (meta.size() != 21 || meta.substr(16) != ".part")
          ::unlinkat(ch.uploads.get(), meta.c_str(), 0);
        continue;
      }
      const std::string text = readSmall(ch.uploads.get(), meta.c_str());
      const size_t nl = text.find('\n');
      const std::string part = meta.substr(0, 16) + ".part";
      Upload u;
      u.channel = name;
      u.fd = Fd(::openat(ch.uploads.get(), part.c_str(), O_RDWR | O_NOFOLLOW | O_CLOEXEC));
      struct stat st {};
      if (nl == std::string::npos || !u.fd.valid() || ::fstat(u.fd.get(), &st) != 0) {
        ::unlinkat(ch.uploads.get(), meta.c_str(), 0);
        ::unlinkat(ch.uploads.get(), part.c_str(), 0);
        continue;
      }
      u.total = std::strtoull(text.c_str(), nullptr, 10);
      u.path = text.substr(nl + 1);
      if (!u.path.empty() && u.path.back() == '\n') u.path.pop_back();
      u.received = std::min<uint64_t>(uint64_t(st.st_size), u.total);
      ch.reserved_bytes += u.total;
      ++ch.reserved_count;
      s.uploads.emplace(std::strtoull(meta.substr(0, 16).c_str(), nullptr, 16), std::move(u));
    }
    stored.push_back({name, ch.owner});
    s.channels.emplace(name, std::move(ch));
  }
  // Parts without a meta file are left from a crash between the two: nothing can resume them.
  for (auto& [name, ch] : s.channels) {
    std::vector<std::string> parts;
    (void)forEntries(ch.uploads.get(), [&](const std::string& n, const struct stat&) {
      if (n.size() == 21 && n.substr(16) == ".part") parts.push_back(n);
    });
    for (const auto& p : parts) {
      const uint64_t id = std::strtoull(p.substr(0, 16).c_str(), nullptr, 16);
      if (s.uploads.count(id) == 0) ::unlinkat(ch.uploads.get(), p.c_str(), 0);
    }
  }
  // Bulk file work yields the CPU to the hub's loop (the relay, service calls, pings): on a
  // machine of two cores a transfer competes with it otherwise (kBulkNice).
  worker_.start();
  return stored;
}

template <class T>
void BlobStore::answer(Done<T> done, Result<T> r) {
  post_([done = std::move(done), r = std::move(r)]() mutable { done(std::move(r)); });
}

void BlobStore::barrier(std::function<void()> done) {
  enqueue([this, done = std::move(done)]() mutable { post_(std::move(done)); });
}

void BlobStore::create(const std::string& channel, const std::string& owner, Done<void> done) {
  enqueue([this, channel, owner, done = std::move(done)]() mutable {
    State& s = *state_;
    const auto made = [&]() -> Result<void> {
      if (auto it = s.channels.find(channel); it != s.channels.end()) {
        if (it->second.owner == owner) return {};
        return makeError(Errc::already_exists,
                         "the blob store " + channel + " belongs to " + it->second.owner);
      }
      Channel ch;
      ch.owner = owner;
      auto dir = openOrMakeDir(s.root.get(), channel);
      if (!dir) return dir.error();
      ch.dir = std::move(dir).value();
      auto files = openOrMakeDir(ch.dir.get(), "files");
      if (!files) return files.error();
      auto uploads = openOrMakeDir(ch.dir.get(), "uploads");
      if (!uploads) return uploads.error();
      ch.files = std::move(files).value();
      ch.uploads = std::move(uploads).value();
      measure(ch.files.get(), ch.bytes, ch.count);  // a tree left by an earlier life
      if (auto w = writeSmall(*io_, ch.dir.get(), "owner", owner); !w) return w;
      if (auto d = io_->syncDir(ch.dir.get()); !d) return d;
      if (auto d = io_->syncDir(s.root.get()); !d) return d;
      s.channels.emplace(channel, std::move(ch));
      return {};
    }();
    answer(std::move(done), made);
  });
}

void BlobStore::drop(const std::string& channel, Done<void> done) {
  enqueue([this, channel, done = std::move(done)]() mutable {
    State& s = *state_;
    std::erase_if(s.uploads, [&](const auto& u) { return u.second.channel == channel; });
    std::erase_if(s.reads, [&](const auto& r) { return r.second.channel == channel; });
    if (s.channels.erase(channel) == 0) {
      answer(std::move(done), Result<void>{});
      return;
    }
    // Renamed first, so a hub that dies while deleting does not bring back half a store.
    const std::string doomed = "#removed-" + hex16(s.rng());
    if (::renameat(s.root.get(), channel.c_str(), s.root.get(), doomed.c_str()) != 0) {
      answer(std::move(done), Result<void>(fsError(errno, channel)));
      return;
    }
    (void)io_->syncDir(s.root.get());
    removeTree(s.root.get(), doomed);
    answer(std::move(done), Result<void>{});
  });
}

void BlobStore::list(const std::string& channel, const std::string& dir, Done<Variant> done) {
  enqueue([this, channel, dir, done = std::move(done)]() mutable {
    const auto listed = [&]() -> Result<Variant> {
      auto ch = state_->channel(channel);
      if (!ch) return ch.error();
      auto parts = blob::splitPath(dir, true);
      if (!parts) return parts.error();
      auto fd = blob::openDirBeneath((*ch)->files.get(), *parts, parts->size());
      if (!fd) return fd.error();
      std::map<std::string, Variant> sorted;
      auto r = forEntries(fd->get(), [&](const std::string& name, const struct stat& st) {
        const bool is_dir = S_ISDIR(st.st_mode);
        if (!is_dir && !S_ISREG(st.st_mode)) return;  // symlinks and the like are not served
        Variant::Map m;
        m["name"] = Variant(name);
        m["dir"] = Variant(is_dir);
        m["size"] = Variant(uint64_t(is_dir ? 0 : st.st_size));
        m["mtime_ns"] = Variant(mtimeNs(st));
        m["version"] = Variant(is_dir ? uint64_t(0) : versionOf(st));
        sorted.emplace(name, Variant(std::move(m)));
      });
      if (!r) return r.error();
      Variant::List out;
      for (auto& [n, v] : sorted) out.push_back(std::move(v));
      return Variant(std::move(out));
    }();
    answer(std::move(done), std::move(listed));
  });
}

void BlobStore::get(uint32_t reader, const std::string& channel, const std::string& path,
                    uint64_t version, uint64_t offset, uint32_t max_bytes, size_t head_room,
                    Done<Read> done) {
  enqueue([=, this, done = std::move(done)]() mutable {
    const auto read = [&]() -> Result<Read> {
      State& s = *state_;
      auto ch = s.channel(channel);
      if (!ch) return ch.error();
      auto it = s.reads.find(reader);
      const bool reuse = it != s.reads.end() && it->second.channel == channel &&
                         it->second.path == path && version != 0 && it->second.version == version;
      if (!reuse) {
        if (it != s.reads.end()) s.reads.erase(it);
        auto opened = openReading(channel, path);
        if (!opened) return opened.error();
        Reading r = std::move(opened).value();
        if (version != 0 && version != r.version) {
          return makeError(Errc::not_found, "version " + std::to_string(version) + " of " + path +
                                                " is gone (it was replaced): read it again");
        }
        it = s.reads.insert_or_assign(reader, std::move(r)).first;
      }
      Reading& r = it->second;
      if (offset > r.size) {
        return makeError(Errc::invalid_argument, "offset " + std::to_string(offset) +
                                                     " is past the end of " + path + " (" +
                                                     std::to_string(r.size) + " bytes)");
      }
      Read out;
      out.version = r.version;
      out.total_size = r.size;
      const uint64_t want = std::min<uint64_t>({max_bytes, kMaxChunk, r.size - offset});
      out.head = head_room;
      out.data.resize(head_room + want);
      char* const into = out.data.data() + head_room;
      size_t got = 0;
      while (got < want) {
        const ssize_t n = ::pread(r.fd.get(), into + got, want - got, off_t(offset + got));
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return fsError(errno, path);
        if (n == 0) break;
        got += size_t(n);
      }
      out.data.resize(head_room + got);
      if (offset + got >= r.size) s.reads.erase(reader);  // read to its end
      return out;
    }();
    answer(std::move(done), std::move(read));
  });
}

Result<BlobStore::Reading> BlobStore::openReading(const std::string& channel,
                                                  const std::string& path) {
  auto ch = state_->channel(channel);
  if (!ch) return ch.error();
  auto at = locate((*ch)->files.get(), path, false);
  if (!at) return at.error();
  Reading r;
  r.channel = channel;
  r.path = path;
  r.fd = Fd(::openat(at->parent.get(), at->name.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
  if (!r.fd.valid()) return fsError(errno, path);
  struct stat st {};
  if (::fstat(r.fd.get(), &st) != 0) return fsError(errno, path);
  if (!S_ISREG(st.st_mode)) return makeError(Errc::invalid_argument, path + " is not a file");
  r.version = versionOf(st);
  r.size = uint64_t(st.st_size);
  return r;
}

void BlobStore::readAll(const std::string& channel, const std::string& path, uint64_t max_bytes,
                        Done<Read> done) {
  enqueue([=, this, done = std::move(done)]() mutable {
    const auto read = [&]() -> Result<Read> {
      auto r = openReading(channel, path);
      if (!r) return r.error();
      if (r->size > max_bytes) {
        return makeError(Errc::limit_exceeded, path + " has " + std::to_string(r->size) +
                                                   " bytes, more than the " +
                                                   std::to_string(max_bytes) + " asked for");
      }
      Read out;
      out.version = r->version;
      out.total_size = r->size;
      out.data.resize(r->size);
      size_t got = 0;
      while (got < r->size) {
        const ssize_t n = ::pread(r->fd.get(), out.data.data() + got, r->size - got, off_t(got));
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return fsError(errno, path);
        if (n == 0) break;
        got += size_t(n);
      }
      out.data.resize(got);
      return out;
    }();
    answer(std::move(done), std::move(read));
  });
}

void BlobStore::put(uint32_t writer, const std::string& channel, BlobQuota user_quota,
                    const std::string& path, uint64_t total_size, uint64_t upload_id,
                    Done<PutAt> done) {
  enqueue([=, this, done = std::move(done)]() mutable {
    const auto started = [&]() -> Result<PutAt> {
      State& s = *state_;
      auto found = s.channel(channel);
      if (!found) return found.error();
      Channel& ch = **found;
      if (upload_id != 0) {
        auto it = s.uploads.find(upload_id);
        if (it == s.uploads.end() || it->second.channel != channel) {
          return makeError(Errc::not_found, "no upload " + std::to_string(upload_id) + " in " +
                                                channel + ": start it again");
        }
        if (it->second.path != path || it->second.total != total_size) {
          return makeError(Errc::invalid_argument, "upload " + std::to_string(upload_id) + " is " +
                                                       it->second.path + " of " +
                                                       std::to_string(it->second.total) + " bytes");
        }
        // Resumed: chunks still coming from the connection that was cut are refused from now
        // on, so the offset given here stays the one to go on from.
        it->second.writer = writer;
        return PutAt{upload_id, it->second.received};
      }
      auto parts = blob::splitPath(path, false);
      if (!parts) return parts.error();
      uint64_t old_size = 0;
      bool exists = false;
      if (auto at = locate(ch.files.get(), path, false); at) {
        struct stat st {};
        if (::fstatat(at->parent.get(), at->name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0) {
          if (S_ISDIR(st.st_mode))
            return makeError(Errc::invalid_argument, path + " is a directory");
          if (S_ISREG(st.st_mode)) {
            exists = true;
            old_size = uint64_t(st.st_size);
          }
        }
      } else if (at.error().code != Errc::not_found) {
        return at.error();
      }
      // Quotas: what the channel and its owner would hold once this upload replaced the file.
      const uint64_t ch_bytes = ch.bytes + ch.reserved_bytes - old_size + total_size;
      const uint64_t ch_files = ch.count + ch.reserved_count + (exists ? 0 : 1);
      if (per_channel_.bytes != 0 && ch_bytes > per_channel_.bytes) {
        return quotaError("channel " + channel, "bytes", ch_bytes, per_channel_.bytes);
      }
      if (per_channel_.files != 0 && ch_files > per_channel_.files) {
        return quotaError("channel " + channel, "files", ch_files, per_channel_.files);
      }
      auto [user_bytes, user_files] = s.usageOf(ch.owner);
      user_bytes = user_bytes - old_size + total_size;
      user_files += exists ? 0 : 1;
      if (user_quota.bytes != 0 && user_bytes > user_quota.bytes) {
        return quotaError("user " + ch.owner, "bytes", user_bytes, user_quota.bytes);
      }
      if (user_quota.files != 0 && user_files > user_quota.files) {
        return quotaError("user " + ch.owner, "files", user_files, user_quota.files);
      }
      uint64_t id = 0;
      while (id == 0 || s.uploads.count(id) != 0) id = s.rng();
      Upload u;
      u.channel = channel;
      u.path = path;
      u.total = total_size;
      u.writer = writer;
      const std::string part = hex16(id) + ".part";
      u.fd = Fd(::openat(ch.uploads.get(), part.c_str(),
                         O_CREAT | O_EXCL | O_RDWR | O_NOFOLLOW | O_CLOEXEC, 0600));
      if (!u.fd.valid()) return fsError(errno, "a new upload");
      const std::string meta = std::to_string(total_size) + "\n" + path + "\n";
      if (auto w = writeSmall(*io_, ch.uploads.get(), hex16(id) + ".meta", meta); !w) {
        ::unlinkat(ch.uploads.get(), part.c_str(), 0);
        return w.error();
      }
      ch.reserved_bytes += total_size;
      ++ch.reserved_count;
      s.uploads.emplace(id, std::move(u));
      return PutAt{id, 0};
    }();
    answer(std::move(done), std::move(started));
  });
}

void BlobStore::chunk(uint32_t writer, const std::string& channel, uint64_t upload_id,
                      uint64_t offset, SharedBytes data, Done<Written> done) {
  enqueue([=, this, data = std::move(data), done = std::move(done)]() mutable {
    const auto written = [&]() -> Result<Written> {
      State& s = *state_;
      auto it = s.uploads.find(upload_id);
      if (it == s.uploads.end() || it->second.channel != channel) {
        return makeError(Errc::not_found, "no upload " + std::to_string(upload_id) + " in " +
                                              channel + ": start it again");
      }
      Upload& u = it->second;
      if (u.writer != writer) {
        return makeError(Errc::invalid_argument, "upload " + std::to_string(upload_id) +
                                                     " was resumed by another connection");
      }
      if (offset != u.received) {
        return makeError(Errc::invalid_argument,
                         "upload " + std::to_string(upload_id) + " goes on at offset " +
                             std::to_string(u.received) + ", not " + std::to_string(offset));
      }
      if (data.size() > u.total - u.received) {
        return makeError(Errc::invalid_argument, "the chunk goes past the upload's size (" +
                                                     std::to_string(u.total) + " bytes)");
      }
      if (auto w = io_->write(u.fd.get(), data, offset); !w) return w.error();
      u.received += data.size();
      if (u.received < u.total) return Written{u.received, 0, std::nullopt};
      // The last byte: data durable, then renamed into place, then the rename durable.
      Channel& ch = *s.channel(channel).value();
      const std::string id = hex16(upload_id);
      const auto finish = [&]() -> Result<Written> {
        if (auto r = io_->sync(u.fd.get()); !r) return r.error();
        auto at = locate(ch.files.get(), u.path, true);
        if (!at) return at.error();
        struct stat old {};
        bool existed = false;
        if (::fstatat(at->parent.get(), at->name.c_str(), &old, AT_SYMLINK_NOFOLLOW) == 0) {
          if (S_ISDIR(old.st_mode)) {
            return makeError(Errc::invalid_argument, u.path + " is a directory now");
          }
          existed = S_ISREG(old.st_mode);
        }
        if (auto r = io_->rename(ch.uploads.get(), id + ".part", at->parent.get(), at->name); !r) {
          return r.error();
        }
        if (auto r = io_->syncDir(at->parent.get()); !r) return r.error();
        ::unlinkat(ch.uploads.get(), (id + ".meta").c_str(), 0);
        struct stat st {};
        ::fstat(u.fd.get(), &st);
        ch.bytes += u.total - (existed ? uint64_t(old.st_size) : 0);
        ch.count += existed ? 0 : 1;
        const uint64_t v = versionOf(st);
        return Written{u.received, v,
                       BlobEvent{uint8_t(msg::BlobChange::written), u.path, u.total, v}};
      }();
      // Done or failed, the upload ends: a failed commit cannot be resumed.
      ch.reserved_bytes -= u.total;
      --ch.reserved_count;
      if (!finish) {
        ::unlinkat(ch.uploads.get(), (id + ".part").c_str(), 0);
        ::unlinkat(ch.uploads.get(), (id + ".meta").c_str(), 0);
      }
      s.uploads.erase(it);
      return finish;
    }();
    answer(std::move(done), std::move(written));
  });
}

void BlobStore::modify(const std::string& channel, BlobQuota user_quota, const std::string& path,
                       uint64_t offset, SharedBytes data, Done<Written> done) {
  enqueue([=, this, data = std::move(data), done = std::move(done)]() mutable {
    const auto written = [&]() -> Result<Written> {
      State& s = *state_;
      auto found = s.channel(channel);
      if (!found) return found.error();
      Channel& ch = **found;
      auto at = locate(ch.files.get(), path, false);
      if (!at) return at.error();
      Fd src(::openat(at->parent.get(), at->name.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
      if (!src.valid()) return fsError(errno, path);
      struct stat st {};
      if (::fstat(src.get(), &st) != 0) return fsError(errno, path);
      if (!S_ISREG(st.st_mode)) return makeError(Errc::invalid_argument, path + " is not a file");
      const uint64_t size = uint64_t(st.st_size);
      if (offset > size) {
        return makeError(Errc::invalid_argument,
                         "offset " + std::to_string(offset) + " is past the end of " + path);
      }
      const uint64_t new_size = std::max<uint64_t>(size, offset + data.size());
      const uint64_t growth = new_size - size;
      if (per_channel_.bytes != 0 && ch.bytes + ch.reserved_bytes + growth > per_channel_.bytes) {
        return quotaError("channel " + channel, "bytes", ch.bytes + ch.reserved_bytes + growth,
                          per_channel_.bytes);
      }
      if (const uint64_t user = s.usageOf(ch.owner).first + growth;
          user_quota.bytes != 0 && user > user_quota.bytes) {
        return quotaError("user " + ch.owner, "bytes", user, user_quota.bytes);
      }
      // A new whole version: the file copied, the chunk written into the copy, the copy renamed
      // over the file. Costs a copy of the file per modification.
      const std::string tmp = hex16(s.rng()) + ".modify";
      Fd out(::openat(ch.uploads.get(), tmp.c_str(),
                      O_CREAT | O_EXCL | O_RDWR | O_NOFOLLOW | O_CLOEXEC, 0600));
      if (!out.valid()) return fsError(errno, "a copy of " + path);
      const auto made = [&]() -> Result<Written> {
        loff_t in_off = 0;
        while (uint64_t(in_off) < size) {
          const ssize_t n =
              ::copy_file_range(src.get(), &in_off, out.get(), nullptr, size - uint64_t(in_off), 0);
          if (n < 0 && errno == EINTR) continue;
          if (n <= 0) {  // EXDEV, ENOSYS, or a file that shrank: copy by hand
            std::string buf(1 << 20, '\0');
            for (;;) {
              const ssize_t r = ::pread(src.get(), buf.data(), buf.size(), in_off);
              if (r < 0) return fsError(errno, path);
              if (r == 0) break;
              if (auto w = io_->write(out.get(), std::string_view(buf.data(), size_t(r)),
                                      uint64_t(in_off));
                  !w) {
                return w.error();
              }
              in_off += r;
            }
            break;
          }
        }
        if (auto w = io_->write(out.get(), data, offset); !w) return w.error();
        if (auto r = io_->sync(out.get()); !r) return r.error();
        if (auto r = io_->rename(ch.uploads.get(), tmp, at->parent.get(), at->name); !r) {
          return r.error();
        }
        if (auto r = io_->syncDir(at->parent.get()); !r) return r.error();
        struct stat now {};
        ::fstat(out.get(), &now);
        ch.bytes += growth;
        const uint64_t v = versionOf(now);
        return Written{
            uint64_t(now.st_size), v,
            BlobEvent{uint8_t(msg::BlobChange::written), path, uint64_t(now.st_size), v}};
      }();
      if (!made) ::unlinkat(ch.uploads.get(), tmp.c_str(), 0);
      return made;
    }();
    answer(std::move(done), std::move(written));
  });
}

void BlobStore::abort(const std::string& channel, uint64_t upload_id, Done<void> done) {
  enqueue([=, this, done = std::move(done)]() mutable {
    State& s = *state_;
    auto it = s.uploads.find(upload_id);
    if (it == s.uploads.end() || it->second.channel != channel) {
      answer(std::move(done),
             Result<void>(makeError(Errc::not_found, "no upload " + std::to_string(upload_id))));
      return;
    }
    Channel& ch = *s.channel(channel).value();
    const std::string id = hex16(upload_id);
    ::unlinkat(ch.uploads.get(), (id + ".part").c_str(), 0);
    ::unlinkat(ch.uploads.get(), (id + ".meta").c_str(), 0);
    ch.reserved_bytes -= it->second.total;
    --ch.reserved_count;
    s.uploads.erase(it);
    answer(std::move(done), Result<void>{});
  });
}

void BlobStore::onPath(const std::string& channel, const std::string& path, bool make, PathOp op,
                       Done<BlobEvent> done) {
  enqueue([=, this, op = std::move(op), done = std::move(done)]() mutable {
    const auto changed = [&]() -> Result<BlobEvent> {
      auto ch = state_->channel(channel);
      if (!ch) return ch.error();
      auto at = locate((*ch)->files.get(), path, make);
      if (!at) return at.error();
      auto ev = op(**ch, at->parent.get(), at->name);
      if (!ev) return ev;
      if (auto r = io_->syncDir(at->parent.get()); !r) return r.error();
      return ev;
    }();
    answer(std::move(done), std::move(changed));
  });
}

void BlobStore::mkdir(const std::string& channel, const std::string& path, Done<BlobEvent> done) {
  onPath(
      channel, path, true,
      [path](Channel&, int parent, const std::string& name) -> Result<BlobEvent> {
        if (::mkdirat(parent, name.c_str(), 0700) != 0) return fsError(errno, path);
        return BlobEvent{uint8_t(msg::BlobChange::dir_added), path, 0, 0};
      },
      std::move(done));
}

void BlobStore::rmdir(const std::string& channel, const std::string& path, Done<BlobEvent> done) {
  onPath(
      channel, path, false,
      [path](Channel&, int parent, const std::string& name) -> Result<BlobEvent> {
        if (::unlinkat(parent, name.c_str(), AT_REMOVEDIR) != 0) return fsError(errno, path);
        return BlobEvent{uint8_t(msg::BlobChange::dir_removed), path, 0, 0};
      },
      std::move(done));
}

void BlobStore::remove(const std::string& channel, const std::string& path, Done<BlobEvent> done) {
  onPath(
      channel, path, false,
      [path](Channel& ch, int parent, const std::string& name) -> Result<BlobEvent> {
        struct stat st {};
        if (::fstatat(parent, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) {
          return fsError(errno, path);
        }
        if (S_ISDIR(st.st_mode)) {
          return makeError(Errc::invalid_argument, path + " is a directory: use rmdir");
        }
        if (::unlinkat(parent, name.c_str(), 0) != 0) return fsError(errno, path);
        if (S_ISREG(st.st_mode)) {
          ch.bytes -= std::min<uint64_t>(ch.bytes, uint64_t(st.st_size));
          if (ch.count > 0) --ch.count;
        }
        return BlobEvent{uint8_t(msg::BlobChange::removed), path, 0, 0};
      },
      std::move(done));
}

void BlobStore::forget(uint32_t reader) {
  enqueue([this, reader] { state_->reads.erase(reader); });
}

}  // namespace skr::flow
