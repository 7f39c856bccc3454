// SPDX-License-Identifier: Apache-2.0
// The database log's format (see database_log.h).
#include "families/databases/database_log.h"

#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/runtime/flow/bytes.h>

#include <json/writer.h>

#include <algorithm>
#include <array>

namespace skr::flow::dblog {
namespace {

constexpr size_t kRecordHeaderBytes = 8;        // length, CRC
constexpr size_t kMinPayloadBytes = 8 + 1 + 2;  // version, op, key length

constexpr std::array<uint32_t, 256> makeTable() {
  std::array<uint32_t, 256> t{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0x82F63B78u ^ (c >> 1) : c >> 1;
    t[i] = c;
  }
  return t;
}
constexpr std::array<uint32_t, 256> kTable = makeTable();

// The record in `payload`, or why it is not one.
Result<Record> decodePayload(std::string_view payload) {
  ByteReader r(payload);
  Record rec;
  uint8_t op = 0;
  std::string_view key;
  if (!r.u64(rec.version) || !r.u8(op) || !r.str16(key)) {
    return makeError(Errc::parse_error, "truncated record");
  }
  if (op < uint8_t(Op::set) || op > uint8_t(Op::drop)) {
    return makeError(Errc::parse_error, "unknown operation " + std::to_string(op));
  }
  rec.op = static_cast<Op>(op);
  rec.key.assign(key);
  if (rec.op == Op::set) {
    DecodeLimits limits;
    limits.max_depth = kDatabaseMaxDepth;
    auto v = decodeVariant(r, limits);
    if (!v) return makeError(Errc::parse_error, "bad value: " + v.error().message);
    rec.value = std::move(v).value();
  }
  if (r.remaining() != 0) return makeError(Errc::parse_error, "bytes after the record's value");
  if (!isValidUtf8(rec.key)) return makeError(Errc::parse_error, "key is not valid UTF-8");
  return rec;
}

bool allZero(std::string_view s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return c == 0; });
}

}  // namespace

uint32_t crc32c(std::string_view data) noexcept {
  uint32_t c = 0xFFFFFFFFu;
  for (const char ch : data) c = kTable[(c ^ static_cast<uint8_t>(ch)) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

void appendRecord(std::string& out, uint64_t version, Op op, std::string_view key,
                  const Variant* value) {
  const size_t start = out.size();
  ByteWriter w(out);
  w.u32(0);
  w.u32(0);
  w.u64(version);
  w.u8(static_cast<uint8_t>(op));
  w.str16(key);
  if (op == Op::set && value != nullptr) encodeVariant(*value, w);
  const std::string_view payload(out.data() + start + kRecordHeaderBytes,
                                 out.size() - start - kRecordHeaderBytes);
  w.patchU32(start, static_cast<uint32_t>(payload.size()));
  w.patchU32(start + 4, crc32c(payload));
}

std::string snapshotText(const std::string& name, const Variant::Map& pairs, uint64_t version) {
  Json::Value doc(Json::objectValue);
  doc["format"] = 1;
  doc["name"] = name;
  doc["version"] = Json::UInt64(version);
  Json::Value& out = doc["pairs"] = Json::Value(Json::objectValue);
  for (const auto& [key, value] : pairs) out[key] = value.toJson();
  Json::StreamWriterBuilder builder;
  builder["indentation"] = "  ";
  builder["emitUTF8"] = true;
  return Json::writeString(builder, doc) + "\n";
}

Result<Scan> scan(std::string_view file) {
  Scan out;
  if (file.empty()) return out;
  if (!file.starts_with(kHeader)) {
    // A header cut short by a crash while the file was created is still a torn, empty log.
    if (file.size() < kHeader.size() && kHeader.starts_with(file)) {
      out.end = Scan::End::torn;
      out.problem = "the header is incomplete";
      return out;
    }
    return makeError(Errc::parse_error, "not a database log (no SKRDBLG1 header)");
  }
  size_t at = kHeader.size();
  out.good_bytes = at;
  while (at < file.size()) {
    const std::string_view rest = file.substr(at);
    std::string why;
    bool last = false;  // the damage reaches the end of the file
    if (rest.size() < kRecordHeaderBytes) {
      why = "a record header cut short";
      last = true;
    } else {
      ByteReader h(rest);
      uint32_t len = 0, crc = 0;
      (void)h.u32(len);
      (void)h.u32(crc);
      if (len < kMinPayloadBytes || len > kMaxPayloadBytes) {
        why = "a record length of " + std::to_string(len) + " bytes";
        last = allZero(rest);
      } else if (rest.size() - kRecordHeaderBytes < len) {
        why = "a record of " + std::to_string(len) + " bytes cut short at " +
              std::to_string(rest.size() - kRecordHeaderBytes);
        last = true;
      } else {
        const std::string_view payload = rest.substr(kRecordHeaderBytes, len);
        last = rest.size() == kRecordHeaderBytes + len ||
               allZero(rest.substr(kRecordHeaderBytes + len));
        if (crc32c(payload) != crc) {
          why = "a record whose checksum does not match";
        } else if (auto rec = decodePayload(payload); !rec) {
          why = rec.error().message;
          last = false;  // intact but unreadable (a newer format?): never cut away
        } else {
          out.records.push_back(std::move(rec).value());
          at += kRecordHeaderBytes + len;
          out.good_bytes = at;
          continue;
        }
      }
    }
    out.end = last ? Scan::End::torn : Scan::End::corrupt;
    out.problem = why + " at byte " + std::to_string(at);
    break;
  }
  return out;
}

}  // namespace skr::flow::dblog
