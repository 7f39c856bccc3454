// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as the users file (<data_dir>/users.json: accounts, argon2id
// hashes, roles, rules, limits; core/src/flow/families/session/accounts.cpp), which the hub reads
// at start and on every change. Loading must never crash; an accepted file's accounts must have
// valid names and rules that write back to JSON and read back equal.
//
//   cmake --preset fuzz && cmake --build --preset fuzz && build/fuzz/bin/users_file_fuzz
#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/log.h>

#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

using namespace skr::flow;

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "users_file_fuzz: %s\n", what.c_str());
  std::abort();
}

// The input as a file with a path, in memory (a memfd is a regular file, as the loader wants).
class MemFile {
 public:
  MemFile(const uint8_t* data, size_t size) : fd_(::memfd_create("users.json", MFD_CLOEXEC)) {
    if (fd_ < 0) fail("memfd_create");
    ::fchmod(fd_, 0600);
    for (size_t done = 0; done < size;) {
      const ssize_t n = ::write(fd_, data + done, size - done);
      if (n <= 0) fail("write");
      done += static_cast<size_t>(n);
    }
  }
  ~MemFile() { ::close(fd_); }
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;
  [[nodiscard]] std::string path() const { return "/proc/self/fd/" + std::to_string(fd_); }

 private:
  int fd_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool quiet = [] {
    skr::log::setLevel(skr::log::Level::error);
    return true;
  }();
  (void)quiet;
  const MemFile file(data, size);
  auto users = UsersFile::load(file.path());
  if (!users) return 0;
  for (const std::string& name : users->names()) {
    if (!validateUserName(name)) fail("an invalid user name was accepted: " + name);
    auto access = users->accessOf(name);
    if (!access) fail("an account without rules: " + name);
    Json::Value entry(Json::objectValue);
    access->toJson(entry);
    auto again = AccessRules::fromJson(entry, "users." + name);
    if (!again) fail("rules that do not read back: " + again.error().message);
    Json::Value twice(Json::objectValue);
    again->toJson(twice);
    if (twice != entry) fail("rules that read back different for " + name);
  }
  return 0;
}
