// SPDX-License-Identifier: Apache-2.0
// The web port's static files (web_files.h): resolution beneath a directory, reads on libuv's
// thread pool.
#include "web_files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <uv.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <optional>

namespace skr::flow {
namespace {

namespace fs = std::filesystem;

Result<blob::Fd> openDir(const fs::path& dir, const std::string& what) {
  blob::Fd fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!fd.valid()) {
    const int err = errno;
    return makeError(err == ENOENT ? Errc::not_found : Errc::io_error,
                     what + " " + dir.string() + ": " + std::strerror(err));
  }
  return fd;
}

Error notFound(const std::string& path) {
  return makeError(Errc::not_found, "no file " + path);
}

// Opens `rel` (decoded, relative) beneath `dir`; a directory gives its index.html.
Result<WebFile> openBeneath(int dir, const std::string& rel) {
  auto parts = blob::splitPath(rel, true);
  if (!parts) return notFound(rel);
  for (const std::string& p : *parts) {
    if (p.front() == '.') return notFound(rel);  // dot files (.git, .env) are never served
  }
  for (int attempt = 0; attempt < 2; ++attempt) {
    std::vector<std::string>& v = *parts;
    if (v.empty()) v.emplace_back("index.html");
    auto parent = blob::openDirBeneath(dir, v, v.size() - 1);
    if (!parent) return notFound(rel);  // missing, a symlink, or leaving the tree
    blob::Fd fd(::openat(parent->get(), v.back().c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC));
    if (!fd.valid()) {
      if (errno == ENOENT || errno == ELOOP || errno == ENOTDIR || errno == EACCES) {
        return notFound(rel);
      }
      return makeError(Errc::io_error, rel + ": " + std::strerror(errno));
    }
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0) return makeError(Errc::io_error, rel + ": fstat failed");
    if (S_ISDIR(st.st_mode)) {
      if (attempt == 0) {
        v.emplace_back("index.html");
        continue;
      }
      return notFound(rel);
    }
    if (!S_ISREG(st.st_mode)) return notFound(rel);
    WebFile f;
    f.content_type = std::string(WebFiles::contentType(v.back()));
    f.size = static_cast<uint64_t>(st.st_size);
    f.fd = std::move(fd);
    return f;
  }
  return notFound(rel);
}

Result<WebFile> readChunk(WebFile f) {
  const size_t want =
      static_cast<size_t>(std::min<uint64_t>(WebFiles::kChunkBytes, f.size - f.offset));
  f.chunk.resize(want);
  size_t got = 0;
  while (got < want) {
    const ssize_t n =
        ::pread(f.fd.get(), f.chunk.data() + got, want - got, static_cast<off_t>(f.offset + got));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return makeError(Errc::io_error, std::string("read: ") + std::strerror(errno));
    if (n == 0) return makeError(Errc::io_error, "the file shrank while it was served");
    got += static_cast<size_t>(n);
  }
  f.offset += want;
  return f;
}

struct Job {
  uv_work_t req{};
  std::function<Result<WebFile>()> work;
  std::optional<Result<WebFile>> result;
  std::weak_ptr<void> alive;
  WebFiles::Done done;
};

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

WebFiles::WebFiles(Loop& loop, std::shared_ptr<const Dirs> dirs)
    : loop_(loop), dirs_(std::move(dirs)) {}

Result<std::unique_ptr<WebFiles>> WebFiles::open(
    Loop& loop, const fs::path& root, const std::vector<std::pair<std::string, fs::path>>& mounts) {
  auto dirs = std::make_shared<Dirs>();
  for (const auto& [prefix, dir] : mounts) {
    auto fd = openDir(dir, "server.web.mounts[\"" + prefix + "\"]");
    if (!fd) return fd.error();
    dirs->emplace_back(prefix, std::move(fd).value());
  }
  std::sort(dirs->begin(), dirs->end(),
            [](const auto& a, const auto& b) { return a.first.size() > b.first.size(); });
  if (!root.empty()) {
    auto fd = openDir(root, "server.web.root");
    if (!fd) return fd.error();
    dirs->emplace_back("", std::move(fd).value());
  }
  return std::make_unique<WebFiles>(loop, std::move(dirs));
}

void WebFiles::open(std::string_view url_path, bool head_only, std::weak_ptr<void> alive,
                    Done done) {
  auto decoded = percentDecode(url_path);
  if (!decoded || decoded->empty() || decoded->front() != '/') {
    done(makeError(Errc::invalid_argument, "a path that cannot be decoded"));
    return;
  }
  const std::string path = std::move(decoded).value();
  int dir = -1;
  std::string rel;
  for (const auto& [prefix, fd] : *dirs_) {
    if (prefix.empty() || (path.starts_with(prefix) &&
                           (path.size() == prefix.size() || path[prefix.size()] == '/'))) {
      dir = fd.get();
      rel = path.substr(std::min(path.size(), prefix.size() + 1));
      break;
    }
  }
  if (dir < 0) {
    done(notFound(path));
    return;
  }
  queue(
      [dirs = dirs_, dir, rel, head_only]() -> Result<WebFile> {
        auto f = openBeneath(dir, rel);
        if (!f || head_only || f->size == 0) return f;
        return readChunk(std::move(f).value());
      },
      std::move(alive), std::move(done));
}

void WebFiles::next(WebFile file, std::weak_ptr<void> alive, Done done) {
  auto shared = std::make_shared<WebFile>(std::move(file));
  queue([shared]() { return readChunk(std::move(*shared)); }, std::move(alive), std::move(done));
}

void WebFiles::queue(std::function<Result<WebFile>()> work, std::weak_ptr<void> alive, Done done) {
  auto* job = new Job;
  job->req.data = job;
  job->work = std::move(work);
  job->alive = std::move(alive);
  job->done = std::move(done);
  const int rc = uv_queue_work(
      loop_.uv(), &job->req,
      [](uv_work_t* r) {
        auto* j = static_cast<Job*>(r->data);
        try {
          j->result = j->work();
        } catch (const std::exception& e) {
          j->result = makeError(Errc::exception, e.what());
        }
      },
      [](uv_work_t* r, int status) {
        std::unique_ptr<Job> j(static_cast<Job*>(r->data));
        if (j->alive.expired()) return;  // its connection went: the file closes here
        if (status != 0 || !j->result) {
          j->done(makeError(Errc::io_error, "the read was cancelled"));
          return;
        }
        j->done(std::move(*j->result));
      });
  if (rc != 0) {
    std::unique_ptr<Job> j(job);
    j->done(makeError(Errc::io_error, std::string("uv_queue_work: ") + uv_strerror(rc)));
  }
}

std::string_view WebFiles::contentType(std::string_view name) noexcept {
  static constexpr std::pair<std::string_view, std::string_view> kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript"},
      {".mjs", "text/javascript"},
      {".css", "text/css"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".txt", "text/plain; charset=utf-8"},
      {".glb", "model/gltf-binary"},
      {".wasm", "application/wasm"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".jpeg", "image/jpeg"},
      {".ico", "image/x-icon"},
      {".woff2", "font/woff2"},
  };
  for (const auto& [ext, type] : kTypes) {
    if (name.ends_with(ext)) return type;
  }
  return "application/octet-stream";
}

Result<std::string> WebFiles::percentDecode(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '%') {
      out += text[i];
      continue;
    }
    const int hi = i + 2 < text.size() ? hexValue(text[i + 1]) : -1;
    const int lo = i + 2 < text.size() ? hexValue(text[i + 2]) : -1;
    if (hi < 0 || lo < 0) return makeError(Errc::invalid_argument, "a bad %-escape");
    const char c = static_cast<char>(hi * 16 + lo);
    if (c == '\0') return makeError(Errc::invalid_argument, "an encoded NUL");
    out += c;
    i += 2;
  }
  return out;
}

}  // namespace skr::flow
