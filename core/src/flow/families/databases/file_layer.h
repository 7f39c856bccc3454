// SPDX-License-Identifier: Apache-2.0
// FileLayer: the file operations of the database store (and replaceFile, which the users file
// uses too), behind an interface so that a test can put a simulated disk underneath and cut its
// power (tests/flow/database_durability_test.cpp):
// what counts is which data and which directory entries were made durable by sync() and
// syncDir() before the cut, not what a process crash (kill -9) happens to leave in the page cache.
//
// PosixFiles is the real one. Thread-safe: the store reads at start on the loop thread and its
// journal writes on its own thread.
#pragma once

#include <skrobot/runtime/result.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow {

class FileLayer {
 public:
  // An open file, written at its end.
  class File {
   public:
    virtual ~File() = default;
    [[nodiscard]] virtual Result<void> append(std::string_view data) = 0;
    // Makes the file's data durable (fdatasync).
    [[nodiscard]] virtual Result<void> sync() = 0;
    [[nodiscard]] virtual uint64_t size() const = 0;
  };

  virtual ~FileLayer() = default;
  // Opens for appending, creating the file (mode 0600) when missing; `truncate` empties it.
  [[nodiscard]] virtual Result<std::unique_ptr<File>> open(const std::filesystem::path& path,
                                                           bool truncate) = 0;
  // The whole file; Errc::not_found when it does not exist.
  [[nodiscard]] virtual Result<std::string> read(const std::filesystem::path& path) = 0;
  // Cuts the file to `size` bytes and makes that durable.
  [[nodiscard]] virtual Result<void> truncate(const std::filesystem::path& path, uint64_t size) = 0;
  [[nodiscard]] virtual Result<void> rename(const std::filesystem::path& from,
                                            const std::filesystem::path& to) = 0;
  // Errc::not_found when it does not exist.
  [[nodiscard]] virtual Result<void> remove(const std::filesystem::path& path) = 0;
  // Makes the directory's entries (creations, renames, removals) durable.
  [[nodiscard]] virtual Result<void> syncDir(const std::filesystem::path& dir) = 0;
  // Creates `dir` (mode 0700) and missing parents; syncs the parent of what it created.
  [[nodiscard]] virtual Result<void> makeDir(const std::filesystem::path& dir) = 0;
  // The names of the regular files in `dir` (empty when it does not exist).
  [[nodiscard]] virtual Result<std::vector<std::string>> list(const std::filesystem::path& dir) = 0;
  [[nodiscard]] virtual bool exists(const std::filesystem::path& path) = 0;
};

// The operating system's files.
[[nodiscard]] std::shared_ptr<FileLayer> posixFiles();

// Writes `content` to dir/file crash-safely: a temporary file dir/file.tmp-<pid>, synced, renamed
// over dir/file, then the directory synced. After a crash at any point the file is the old one or
// the new one, never a mix.
[[nodiscard]] Result<void> replaceFile(FileLayer& files, const std::filesystem::path& dir,
                                       const std::string& file, std::string_view content);

}  // namespace skr::flow
