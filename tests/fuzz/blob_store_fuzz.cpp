// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as the files a blob store reads at start
// (<data_dir>/blobs/<channel>/owner and uploads/<id>.meta,
// core/src/flow/families/blobs/blob_store.cpp), as a hub finds them after a crash or a hand edit.
// Opening must never crash; an upload it keeps must be resumable (a size it holds no more than, a
// path the rules accept) or it is dropped.
//
//   cmake --preset fuzz && cmake --build --preset fuzz && build/fuzz/bin/blob_store_fuzz
#include "families/blobs/blob_path.h"
#include "families/blobs/blob_store.h"

#include <skrobot/runtime/log.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <string>
#include <string_view>

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "blob_store_fuzz: %s\n", what);
  std::abort();
}

const fs::path& root() {
  static const fs::path dir = [] {
    char tmpl[] = "/tmp/blob_store_fuzz-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr) fail("mkdtemp");
    skr::log::setLevel(skr::log::Level::error);
    return fs::path(tmpl);
  }();
  return dir;
}

void write(const fs::path& p, std::string_view bytes) {
  std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  // The first half is the owner file, the rest an upload's meta file (its part holds 3 bytes).
  const size_t cut = in.size() / 2;
  const fs::path blobs = root() / "blobs", ch = blobs / "guest.maps";
  fs::remove_all(blobs);
  fs::create_directories(ch / "files");
  fs::create_directories(ch / "uploads");
  write(ch / "owner", in.substr(0, cut));
  write(ch / "uploads" / "00000000000000aa.meta", in.substr(cut));
  write(ch / "uploads" / "00000000000000aa.part", "abc");
  skr::flow::BlobStore store(blobs, {}, [](std::function<void()> fn) { fn(); });
  auto stored = store.open();
  if (!stored) return 0;
  // A kept upload resumes where its part ends, or is refused; never a crash.
  for (const auto& s : *stored) {
    std::promise<void> done;
    store.put(1, s.name, {}, "x", 3, 0xaa, [&](auto) { done.set_value(); });
    done.get_future().wait();
  }
  return 0;
}
