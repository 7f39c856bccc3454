// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as a blob channel path (BLOB_* requests carry them from any
// satellite; core/src/flow/families/blobs/blob_path.h). splitPath must never crash; what it accepts
// must obey the rules (no empty, ".", ".." component, no NUL or backslash, bounded lengths and
// depth) and join back to the input; and opening it beneath a directory must stay beneath it.
//
//   cmake --preset fuzz && cmake --build --preset fuzz && build/fuzz/bin/blob_path_fuzz
#include "families/blobs/blob_path.h"

#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "blob_path_fuzz: %s\n", what);
  std::abort();
}

// A directory with a subdirectory "a" and a symlink "out" to "/", made once.
int root() {
  static const int fd = [] {
    char tmpl[] = "/tmp/blob_path_fuzz-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr) fail("mkdtemp");
    const int d = ::open(tmpl, O_RDONLY | O_DIRECTORY);
    ::mkdirat(d, "a", 0700);
    ::symlinkat("/", d, "out");
    return d;
  }();
  return fd;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view path(reinterpret_cast<const char*>(data), size);
  using namespace skr::flow::blob;
  for (const bool root_ok : {false, true}) {
    auto parts = splitPath(path, root_ok);
    if (!parts) continue;
    if (path.size() > kMaxPathBytes || parts->size() > kMaxDepth) fail("a limit was not kept");
    std::string joined;
    for (const auto& p : *parts) {
      if (p.empty() || p == "." || p == ".." || p.size() > kMaxComponentBytes) {
        fail("a bad component was accepted");
      }
      if (p.find('/') != std::string::npos || p.find('\\') != std::string::npos ||
          p.find('\0') != std::string::npos) {
        fail("a separator or NUL inside a component");
      }
      if (!joined.empty()) joined += '/';
      joined += p;
    }
    if (joined != path) fail("the components do not join back to the path");
    // Opening it beneath the root never follows "out" (a symlink to /).
    if (!parts->empty() && (*parts)[0] == "out") {
      if (openDirBeneath(root(), *parts, parts->size())) fail("followed a symlink out");
    } else {
      (void)openDirBeneath(root(), *parts, parts->size());
    }
  }
  return 0;
}
