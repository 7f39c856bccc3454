// SPDX-License-Identifier: Apache-2.0
// Paths of blob channels and their confinement: a path a satellite names is checked (relative,
// '/'-separated, no '.', '..', empty, NUL or backslash components, bounded lengths and depth),
// then resolved beneath the channel's directory so that nothing on disk (a symlink planted in the
// tree, a directory swapped for a symlink while a path is being opened) leads outside it.
//
// Resolution uses openat2(RESOLVE_BENEATH | RESOLVE_NO_SYMLINKS) where the kernel and the sandbox
// allow it, else a walk of openat(O_NOFOLLOW | O_DIRECTORY) per component. Operations on the last
// component then use the parent's descriptor with the *at calls, never following a symlink.
#pragma once

#include <skrobot/runtime/result.h>

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow::blob {

inline constexpr size_t kMaxComponentBytes = 255;
inline constexpr size_t kMaxDepth = 32;
inline constexpr size_t kMaxPathBytes = 1024;

// The components of `path`, checked; an empty path is the root (no components), allowed only
// where `root_ok`. invalid_argument naming the rule broken.
[[nodiscard]] Result<std::vector<std::string>> splitPath(std::string_view path, bool root_ok);

// A file descriptor, closed on destruction.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) noexcept : fd_(fd) {}
  ~Fd();
  Fd(Fd&& o) noexcept : fd_(o.release()) {}
  Fd& operator=(Fd&& o) noexcept;
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  [[nodiscard]] int get() const noexcept { return fd_; }
  [[nodiscard]] bool valid() const noexcept { return fd_ >= 0; }
  int release() noexcept {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_ = -1;
};

enum class Resolver { openat2, walk };

// The resolver in use: openat2 unless the kernel or a seccomp filter refused it (probed once), or
// a test forced the walk.
[[nodiscard]] Resolver resolver() noexcept;
// Tests: forces a resolver (walk is always possible; openat2 only where the probe found it).
void forceResolver(Resolver r) noexcept;
// Tests: called by the walk after it opened the directory of component `depth` (0 for the
// first) and before it opens the next, so that a test can swap what comes next.
void setWalkHook(std::function<void(size_t depth)> hook);

// Opens the directory `parts` beneath `root` (a directory descriptor): every component must be a
// real directory. not_found, permission_denied (a symlink or a non-directory on the way:
// "leaves the channel's tree"), io_error.
[[nodiscard]] Result<Fd> openDirBeneath(int root, const std::vector<std::string>& parts,
                                        size_t count);

// An error for an errno of an *at call on `what`, in the words the protocol answers with.
[[nodiscard]] Error fsError(int err, const std::string& what);

}  // namespace skr::flow::blob
