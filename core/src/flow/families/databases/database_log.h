// SPDX-License-Identifier: Apache-2.0
// The append-only log of a persistent PairDatabase, <data_dir>/db/<name>.log: its byte format and
// its reader. The file is an 8-byte header "SKRDBLG1", then records:
//
//   u32 length of the payload, u32 CRC-32C of the payload, payload:
//   u64 version (the database's version after the change), u8 op, u16 key length, key,
//   and for `set` the value in the binary Variant encoding (docs/flow-protocol.md).
//
// Little-endian. Pure functions: the journal writes, the store reads at start, the fuzz target
// (tests/fuzz/database_log_fuzz.cpp) feeds it anything.
#pragma once

#include <skrobot/runtime/flow/variant.h>
#include <skrobot/runtime/result.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace skr::flow::dblog {

constexpr std::string_view kHeader = "SKRDBLG1";
// A record's payload may hold a 16 MiB value (the limit of PairDatabase::set) and a 64 KiB key.
constexpr uint32_t kMaxPayloadBytes = (16u << 20) + (64u << 10) + 64;

enum class Op : uint8_t {
  set = 1,     // key = value
  remove = 2,  // key removed
  clear = 3,   // every key removed
  drop = 4,    // the database was removed: the files go next
};

struct Record {
  uint64_t version = 0;
  Op op = Op::set;
  std::string key;
  Variant value;  // set only
};

// Appends one record to `out`.
void appendRecord(std::string& out, uint64_t version, Op op, std::string_view key,
                  const Variant* value);

struct Scan {
  enum class End {
    clean,  // every byte belongs to a whole record
    torn,   // the last record is incomplete or damaged, and nothing follows it: a crash mid-append
    corrupt,  // a damaged record with more after it: not a crash's work
  };
  std::vector<Record> records;  // the good ones, up to the first bad one
  uint64_t good_bytes = 0;      // the header and the good records: where a torn log is cut
  End end = End::clean;
  std::string problem;  // what was wrong at good_bytes (torn, corrupt)
};

// Reads a whole log file. Errc::parse_error when it does not start with the header (an empty
// file, a crash while it was being created, is a clean empty log).
[[nodiscard]] Result<Scan> scan(std::string_view file);

// A snapshot file's text, <data_dir>/db/<name>.json: {"format": 1, "name", "version", "pairs"}.
[[nodiscard]] std::string snapshotText(const std::string& name, const Variant::Map& pairs,
                                       uint64_t version);

// CRC-32C (Castagnoli), as iSCSI and ext4 use it.
[[nodiscard]] uint32_t crc32c(std::string_view data) noexcept;

}  // namespace skr::flow::dblog
