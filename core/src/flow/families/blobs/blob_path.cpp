// SPDX-License-Identifier: Apache-2.0
#include "families/blobs/blob_path.h"

#include <fcntl.h>
#include <linux/openat2.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>

namespace skr::flow::blob {

Result<std::vector<std::string>> splitPath(std::string_view path, bool root_ok) {
  const auto bad = [&](const std::string& why) {
    return makeError(Errc::invalid_argument, "bad path: " + why);
  };
  if (path.empty()) {
    if (root_ok) return std::vector<std::string>{};
    return bad("empty");
  }
  if (path.size() > kMaxPathBytes) {
    return bad("longer than " + std::to_string(kMaxPathBytes) + " bytes");
  }
  if (path.front() == '/') return bad("absolute (paths are relative to the channel's root)");
  if (path.find('\0') != std::string_view::npos) return bad("holds a NUL byte");
  if (path.find('\\') != std::string_view::npos) return bad("holds a backslash");
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t slash = path.find('/', start);
    const std::string_view part = path.substr(
        start, slash == std::string_view::npos ? std::string_view::npos : slash - start);
    if (part.empty()) return bad("an empty component (\"//\" or a trailing \"/\")");
    if (part == "." || part == "..") return bad("a \"" + std::string(part) + "\" component");
    if (part.size() > kMaxComponentBytes) {
      return bad("a component longer than " + std::to_string(kMaxComponentBytes) + " bytes");
    }
    parts.emplace_back(part);
    if (parts.size() > kMaxDepth) return bad("deeper than " + std::to_string(kMaxDepth));
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  return parts;
}

Fd::~Fd() {
  if (fd_ >= 0) ::close(fd_);
}

Fd& Fd::operator=(Fd&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.release();
  }
  return *this;
}

namespace {

std::atomic<int> g_forced{-1};  // -1: none, else a Resolver
std::mutex g_hook_mutex;
std::function<void(size_t)> g_hook;

bool openat2Works() {
  static const bool works = [] {
    open_how how{};
    how.flags = O_RDONLY | O_DIRECTORY | O_CLOEXEC;
    how.resolve = RESOLVE_BENEATH | RESOLVE_NO_SYMLINKS;
    const long fd = ::syscall(SYS_openat2, AT_FDCWD, ".", &how, sizeof how);
    if (fd < 0) return false;  // ENOSYS (old kernel), EPERM (seccomp), ...
    ::close(static_cast<int>(fd));
    return true;
  }();
  return works;
}

std::string joined(const std::vector<std::string>& parts, size_t count) {
  std::string s;
  for (size_t i = 0; i < count; ++i) {
    if (i > 0) s += '/';
    s += parts[i];
  }
  return s;
}

}  // namespace

Resolver resolver() noexcept {
  const int forced = g_forced.load();
  if (forced == static_cast<int>(Resolver::walk)) return Resolver::walk;
  return openat2Works() ? Resolver::openat2 : Resolver::walk;
}

void forceResolver(Resolver r) noexcept {
  g_forced.store(static_cast<int>(r));
}

void setWalkHook(std::function<void(size_t)> hook) {
  const std::lock_guard lock(g_hook_mutex);
  g_hook = std::move(hook);
}

Error fsError(int err, const std::string& what) {
  switch (err) {
    case ENOENT:
      return makeError(Errc::not_found, "no such file or directory: " + what);
    case EEXIST:
      return makeError(Errc::already_exists, what + " exists");
    case ELOOP:
    case EXDEV:
    case ENOTDIR:
      // ELOOP: a symlink (O_NOFOLLOW, RESOLVE_NO_SYMLINKS); EXDEV: RESOLVE_BENEATH refused an
      // escape; ENOTDIR: a file where a directory was expected.
      return makeError(
          Errc::permission_denied,
          what + " leaves the channel's tree or is not a directory (" + std::strerror(err) + ")");
    case ENOTEMPTY:
      return makeError(Errc::invalid_argument, what + " is not empty");
    case EISDIR:
      return makeError(Errc::invalid_argument, what + " is a directory");
    case ENOSPC:
    case EDQUOT:
      return makeError(Errc::limit_exceeded, "no space left on the hub's disk for " + what);
    default:
      return makeError(Errc::io_error, what + ": " + std::strerror(err));
  }
}

Result<Fd> openDirBeneath(int root, const std::vector<std::string>& parts, size_t count) {
  constexpr int kDirFlags = O_RDONLY | O_DIRECTORY | O_CLOEXEC;
  if (count == 0) {
    const int fd = ::fcntl(root, F_DUPFD_CLOEXEC, 0);
    if (fd < 0) return fsError(errno, "the channel's root");
    return Fd(fd);
  }
  if (resolver() == Resolver::openat2) {
    open_how how{};
    how.flags = kDirFlags | O_NOFOLLOW;
    how.resolve = RESOLVE_BENEATH | RESOLVE_NO_SYMLINKS | RESOLVE_NO_MAGICLINKS;
    const std::string rel = joined(parts, count);
    long fd;
    do {
      fd = ::syscall(SYS_openat2, root, rel.c_str(), &how, sizeof how);
    } while (fd < 0 && errno == EAGAIN);  // a rename elsewhere raced the lookup: retry
    if (fd < 0) return fsError(errno, rel);
    return Fd(static_cast<int>(fd));
  }
  std::function<void(size_t)> hook;
  {
    const std::lock_guard lock(g_hook_mutex);
    hook = g_hook;
  }
  Fd dir(::fcntl(root, F_DUPFD_CLOEXEC, 0));
  if (!dir.valid()) return fsError(errno, "the channel's root");
  for (size_t i = 0; i < count; ++i) {
    if (i > 0 && hook) hook(i - 1);
    Fd next(::openat(dir.get(), parts[i].c_str(), kDirFlags | O_NOFOLLOW));
    if (!next.valid()) return fsError(errno, joined(parts, i + 1));
    dir = std::move(next);
  }
  return dir;
}

}  // namespace skr::flow::blob
