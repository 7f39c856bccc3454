// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as a database log (<data_dir>/db/<name>.log,
// core/src/flow/families/databases/database_log.h), as the hub reads it at start after a crash. The
// reader must never crash or allocate what a length field announces; its verdict must be consistent
// (a clean log is read to its end, a torn or corrupt one stops at good_bytes); and every record it
// accepts must encode again to the same bytes.
//
//   cmake --preset fuzz && cmake --build --preset fuzz && build/fuzz/bin/database_log_fuzz
#include "families/databases/database_log.h"

#include <skrobot/runtime/flow/bytes.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

namespace {

using namespace skr::flow;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "database_log_fuzz: %s\n", what);
  std::abort();
}

std::string encoded(const Variant& v) {
  std::string out;
  ByteWriter w(out);
  encodeVariant(v, w);
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  // The first byte picks how the rest is read: as it is; after a valid header; or after a valid
  // header with every record's checksum made right, so that the fuzzer reaches the records'
  // contents (it cannot guess a CRC-32C).
  const uint8_t mode = size > 0 ? data[0] % 3 : 0;
  std::string file =
      mode == 0 ? std::string(bytes) : std::string(dblog::kHeader) + std::string(bytes.substr(1));
  if (mode == 2) {
    for (size_t at = dblog::kHeader.size(); at + 8 <= file.size();) {
      uint32_t len = 0;
      std::memcpy(&len, file.data() + at, 4);
      if (len > file.size() - at - 8) break;
      const uint32_t crc = dblog::crc32c(std::string_view(file).substr(at + 8, len));
      std::memcpy(file.data() + at + 4, &crc, 4);
      at += 8 + len;
    }
  }
  auto scanned = dblog::scan(file);
  if (!scanned) return 0;
  const dblog::Scan& s = *scanned;
  if (s.good_bytes > file.size()) fail("good_bytes past the end");
  if (s.end == dblog::Scan::End::clean && !file.empty() && s.good_bytes != file.size()) {
    fail("a clean log not read to its end");
  }
  if (s.end != dblog::Scan::End::clean && s.problem.empty()) fail("a problem without a reason");
  // Every accepted record encodes to a record that reads back equal (the value encoding may have
  // more than one form of a value, so the bytes themselves may differ).
  std::string again(dblog::kHeader);
  for (const dblog::Record& r : s.records) {
    dblog::appendRecord(again, r.version, r.op, r.key, r.op == dblog::Op::set ? &r.value : nullptr);
  }
  auto back = dblog::scan(again);
  if (!back || back->end != dblog::Scan::End::clean) fail("re-encoded records do not read back");
  if (back->records.size() != s.records.size()) fail("a different number of records read back");
  for (size_t i = 0; i < s.records.size(); ++i) {
    const dblog::Record& a = s.records[i];
    const dblog::Record& b = back->records[i];
    // Values compared by their encoding: NaN is not equal to itself.
    if (a.version != b.version || a.op != b.op || a.key != b.key ||
        encoded(a.value) != encoded(b.value)) {
      fail("a record reads back different");
    }
  }
  return 0;
}
