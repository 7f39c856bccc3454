// SPDX-License-Identifier: Apache-2.0
// The real FileLayer: POSIX calls, with errno turned into Errc::io_error (or not_found).
#include "families/databases/file_layer.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace skr::flow {
namespace {

namespace fs = std::filesystem;

Error ioError(const std::string& what, const fs::path& path, int err) {
  return makeError(err == ENOENT ? Errc::not_found : Errc::io_error,
                   what + " " + path.string() + ": " + std::strerror(err));
}

class Fd {
 public:
  explicit Fd(int fd) noexcept : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  [[nodiscard]] int get() const noexcept { return fd_; }
  [[nodiscard]] bool valid() const noexcept { return fd_ >= 0; }

 private:
  int fd_;
};

class PosixFile final : public FileLayer::File {
 public:
  PosixFile(int fd, fs::path path, uint64_t size) : fd_(fd), path_(std::move(path)), size_(size) {}

  Result<void> append(std::string_view data) override {
    while (!data.empty()) {
      const ssize_t n = ::write(fd_.get(), data.data(), data.size());
      if (n < 0) {
        if (errno == EINTR) continue;
        return ioError("cannot write", path_, errno);
      }
      data.remove_prefix(static_cast<size_t>(n));
      size_ += static_cast<uint64_t>(n);
    }
    return {};
  }
  Result<void> sync() override {
    if (::fdatasync(fd_.get()) != 0) return ioError("cannot fsync", path_, errno);
    return {};
  }
  uint64_t size() const override { return size_; }

 private:
  Fd fd_;
  fs::path path_;
  uint64_t size_;
};

class PosixFiles final : public FileLayer {
 public:
  Result<std::unique_ptr<File>> open(const fs::path& path, bool truncate) override {
    const int flags =
        O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC | O_NOFOLLOW | (truncate ? O_TRUNC : 0);
    const int fd = ::open(path.c_str(), flags, 0600);
    if (fd < 0) return ioError("cannot open", path, errno);
    // O_CREAT's mode does not apply to a leftover file of the same name: private, whatever it was.
    if (::fchmod(fd, 0600) != 0) {
      const int err = errno;
      ::close(fd);
      return ioError("cannot chmod", path, err);
    }
    struct stat st {};
    if (::fstat(fd, &st) != 0) {
      const int err = errno;
      ::close(fd);
      return ioError("cannot stat", path, err);
    }
    return std::unique_ptr<File>(
        std::make_unique<PosixFile>(fd, path, static_cast<uint64_t>(st.st_size)));
  }

  Result<std::string> read(const fs::path& path) override {
    Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW));
    if (!fd.valid()) return ioError("cannot open", path, errno);
    std::string out;
    char buf[64 * 1024];
    for (;;) {
      const ssize_t n = ::read(fd.get(), buf, sizeof buf);
      if (n < 0) {
        if (errno == EINTR) continue;
        return ioError("cannot read", path, errno);
      }
      if (n == 0) return out;
      out.append(buf, static_cast<size_t>(n));
    }
  }

  Result<void> truncate(const fs::path& path, uint64_t size) override {
    Fd fd(::open(path.c_str(), O_WRONLY | O_CLOEXEC | O_NOFOLLOW));
    if (!fd.valid()) return ioError("cannot open", path, errno);
    if (::ftruncate(fd.get(), static_cast<off_t>(size)) != 0) {
      return ioError("cannot truncate", path, errno);
    }
    if (::fsync(fd.get()) != 0) return ioError("cannot fsync", path, errno);
    return {};
  }

  Result<void> rename(const fs::path& from, const fs::path& to) override {
    if (::rename(from.c_str(), to.c_str()) != 0) return ioError("cannot rename", from, errno);
    return {};
  }

  Result<void> remove(const fs::path& path) override {
    if (::unlink(path.c_str()) != 0) return ioError("cannot remove", path, errno);
    return {};
  }

  Result<void> syncDir(const fs::path& dir) override {
    Fd fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    if (!fd.valid()) return ioError("cannot open directory", dir, errno);
    if (::fsync(fd.get()) != 0) return ioError("cannot fsync directory", dir, errno);
    return {};
  }

  Result<void> makeDir(const fs::path& dir) override {
    std::error_code ec;
    if (fs::is_directory(dir, ec)) return {};
    if (dir.has_parent_path()) {
      if (auto r = makeDir(dir.parent_path()); !r) return r;
    }
    if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
      return ioError("cannot create directory", dir, errno);
    }
    if (dir.has_parent_path()) return syncDir(dir.parent_path());
    return {};
  }

  Result<std::vector<std::string>> list(const fs::path& dir) override {
    std::vector<std::string> out;
    std::error_code ec;
    if (!fs::exists(dir, ec)) return out;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      if (it->is_regular_file(ec)) out.push_back(it->path().filename().string());
    }
    if (ec) return ioError("cannot list", dir, ec.value());
    return out;
  }

  bool exists(const fs::path& path) override {
    std::error_code ec;
    return fs::exists(path, ec);
  }
};

}  // namespace

std::shared_ptr<FileLayer> posixFiles() {
  static const std::shared_ptr<FileLayer> files = std::make_shared<PosixFiles>();
  return files;
}

Result<void> replaceFile(FileLayer& files, const fs::path& dir, const std::string& file,
                         std::string_view content) {
  const fs::path target = dir / file;
  const fs::path tmp = dir / (file + ".tmp-" + std::to_string(::getpid()));
  Result<void> r = [&]() -> Result<void> {
    auto out = files.open(tmp, true);
    if (!out) return out.error();
    if (auto w = (*out)->append(content); !w) return w;
    if (auto s = (*out)->sync(); !s) return s;
    out->reset();
    return files.rename(tmp, target);
  }();
  if (!r) {
    (void)files.remove(tmp);
    return r;
  }
  return files.syncDir(dir);
}

}  // namespace skr::flow
