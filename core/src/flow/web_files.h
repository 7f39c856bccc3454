// SPDX-License-Identifier: Apache-2.0
// The web port's static files (server.web.root and server.web.mounts): a URL path is decoded,
// matched to the longest mount prefix (else the root), checked as blob paths are (no '.', '..',
// empty or NUL component; no component starting with '.'), then opened beneath that directory
// with openat2(RESOLVE_BENEATH | RESOLVE_NO_SYMLINKS) (blob_path.h): nothing on disk leads
// outside it. A directory serves its index.html.
//
// Threads: open() and next() are called on the loop thread; the opening and every read run on
// libuv's thread pool, and `done` is called back on the loop thread. A request whose owner has
// gone (its `alive` token expired) is dropped there, its file closed.
#pragma once

#include "families/blobs/blob_path.h"

#include <skrobot/runtime/loop.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skr::flow {

// A file being served: its type, size and the chunk read last.
struct WebFile {
  std::string content_type;
  uint64_t size = 0;
  uint64_t offset = 0;  // of the next chunk
  std::string chunk;    // the bytes read last (empty for HEAD)
  blob::Fd fd;
};

class WebFiles {
 public:
  static constexpr size_t kChunkBytes = size_t{256} * 1024;

  // Opens the root and each mount's directory (start, loop thread, once). An empty `root` is
  // allowed (only the mounts serve). Errc::not_found or io_error naming the directory.
  [[nodiscard]] static Result<std::unique_ptr<WebFiles>> open(
      Loop& loop, const std::filesystem::path& root,
      const std::vector<std::pair<std::string, std::filesystem::path>>& mounts);

  using Done = std::function<void(Result<WebFile>)>;
  // Opens `url_path` (the request target's path, still percent-encoded) and reads its first
  // chunk unless `head_only`. not_found (also for what leaves the tree, a symlink, a dot file),
  // invalid_argument (a path that cannot be decoded), io_error.
  void open(std::string_view url_path, bool head_only, std::weak_ptr<void> alive, Done done);
  // Reads the next chunk of `file` (offset < size).
  void next(WebFile file, std::weak_ptr<void> alive, Done done);

  // The Content-Type of a file name, by its extension (application/octet-stream otherwise).
  [[nodiscard]] static std::string_view contentType(std::string_view name) noexcept;
  // "%2e%2E" -> "..": invalid_argument for a bad escape or an encoded NUL.
  [[nodiscard]] static Result<std::string> percentDecode(std::string_view text);

  // Longest prefix first; the root (if any) last, as "". Shared with the reads under way, so
  // that the descriptors outlive them.
  using Dirs = std::vector<std::pair<std::string, blob::Fd>>;
  WebFiles(Loop& loop, std::shared_ptr<const Dirs> dirs);

 private:
  void queue(std::function<Result<WebFile>()> work, std::weak_ptr<void> alive, Done done);

  Loop& loop_;
  std::shared_ptr<const Dirs> dirs_;
};

}  // namespace skr::flow
