// SPDX-License-Identifier: Apache-2.0
// The byte encoding of MCAP records (records.h).
#include <skrobot/mcap/records.h>
#include <skrobot/runtime/flow/bytes.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>

namespace skr::mcap {

namespace {

using flow::ByteReader;
using flow::ByteWriter;

// Writes opcode and a length placeholder; close() patches the length once the content is in.
class RecordWriter {
 public:
  RecordWriter(std::string& out, Op op) : out_(out), w_(out) {
    w_.u8(static_cast<uint8_t>(op));
    length_at_ = out.size();
    w_.u64(0);
  }
  ~RecordWriter() {
    const uint64_t n = out_.size() - length_at_ - 8;
    std::memcpy(out_.data() + length_at_, &n, sizeof n);
  }
  RecordWriter(const RecordWriter&) = delete;
  RecordWriter& operator=(const RecordWriter&) = delete;
  RecordWriter(RecordWriter&&) = delete;
  RecordWriter& operator=(RecordWriter&&) = delete;

  ByteWriter& operator*() { return w_; }
  ByteWriter* operator->() { return &w_; }
  void str(std::string_view s) { w_.str32(s); }
  void strings(const StringMap& m) {
    const size_t at = out_.size();
    w_.u32(0);
    for (const auto& [k, v] : m) {
      w_.str32(k);
      w_.str32(v);
    }
    w_.patchU32(at, static_cast<uint32_t>(out_.size() - at - 4));
  }
  void offsets(const std::map<uint16_t, uint64_t>& m) {
    w_.u32(static_cast<uint32_t>(m.size() * 10));
    for (const auto& [k, v] : m) {
      w_.u16(k);
      w_.u64(v);
    }
  }

 private:
  std::string& out_;
  ByteWriter w_;
  size_t length_at_ = 0;
};

// A ByteReader that remembers the first failure.
class FieldReader {
 public:
  FieldReader(std::string_view content, const char* record) : r_(content), record_(record) {}
  template <typename T>
  FieldReader& num(T& v) {
    if (ok_) ok_ = fixed(v);
    return *this;
  }
  FieldReader& str(std::string& v) {
    std::string_view s;
    if (ok_) ok_ = r_.str32(s);
    if (ok_) v.assign(s);
    return *this;
  }
  FieldReader& strings(StringMap& m) {
    std::string_view block;
    if (ok_) ok_ = r_.str32(block);
    ByteReader in(block);
    while (ok_ && !in.empty()) {
      std::string_view k, v;
      ok_ = in.str32(k) && in.str32(v);
      if (ok_) m.emplace(std::string(k), std::string(v));
    }
    return *this;
  }
  FieldReader& offsets(std::map<uint16_t, uint64_t>& m) {
    std::string_view block;
    if (ok_) ok_ = r_.str32(block) && block.size() % 10 == 0;
    ByteReader in(block);
    while (ok_ && !in.empty()) {
      uint16_t k = 0;
      uint64_t v = 0;
      ok_ = in.u16(k) && in.u64(v);
      if (ok_) m[k] = v;
    }
    return *this;
  }
  FieldReader& bytes64(std::string_view& v) {
    uint64_t n = 0;
    if (ok_) ok_ = r_.u64(n) && n <= r_.remaining() && r_.view(static_cast<size_t>(n), v);
    return *this;
  }
  FieldReader& rest(std::string_view& v) {
    if (ok_) v = r_.rest();
    return *this;
  }
  ByteReader& raw() { return r_; }
  void fail() { ok_ = false; }
  template <typename T>
  Result<T> done(T value) {
    if (!ok_) return makeError(Errc::parse_error, std::string(record_) + " record too short");
    return value;
  }

 private:
  bool fixed(uint8_t& v) { return r_.u8(v); }
  bool fixed(uint16_t& v) { return r_.u16(v); }
  bool fixed(uint32_t& v) { return r_.u32(v); }
  bool fixed(uint64_t& v) { return r_.u64(v); }

  ByteReader r_;
  const char* record_;
  bool ok_ = true;
};

}  // namespace

void append(std::string& out, const Header& r) {
  RecordWriter w(out, Op::header);
  w.str(r.profile);
  w.str(r.library);
}
void append(std::string& out, const Footer& r) {
  RecordWriter w(out, Op::footer);
  w->u64(r.summary_start);
  w->u64(r.summary_offset_start);
  w->u32(r.summary_crc);
}
void append(std::string& out, const Schema& r) {
  RecordWriter w(out, Op::schema);
  w->u16(r.id);
  w.str(r.name);
  w.str(r.encoding);
  w.str(r.data);
}
void append(std::string& out, const Channel& r) {
  RecordWriter w(out, Op::channel);
  w->u16(r.id);
  w->u16(r.schema_id);
  w.str(r.topic);
  w.str(r.message_encoding);
  w.strings(r.metadata);
}
void append(std::string& out, const Message& r) {
  RecordWriter w(out, Op::message);
  w->u16(r.channel_id);
  w->u32(r.sequence);
  w->u64(r.log_time);
  w->u64(r.publish_time);
  w->raw(r.data);
}
void append(std::string& out, const Chunk& r) {
  RecordWriter w(out, Op::chunk);
  w->u64(r.message_start_time);
  w->u64(r.message_end_time);
  w->u64(r.uncompressed_size);
  w->u32(r.uncompressed_crc);
  w.str(r.compression);
  w->u64(r.records.size());
  w->raw(r.records);
}
void append(std::string& out, const MessageIndex& r) {
  RecordWriter w(out, Op::message_index);
  w->u16(r.channel_id);
  w->u32(static_cast<uint32_t>(r.records.size() * 16));
  for (const auto& [time, offset] : r.records) {
    w->u64(time);
    w->u64(offset);
  }
}
void append(std::string& out, const ChunkIndex& r) {
  RecordWriter w(out, Op::chunk_index);
  w->u64(r.message_start_time);
  w->u64(r.message_end_time);
  w->u64(r.chunk_start_offset);
  w->u64(r.chunk_length);
  w.offsets(r.message_index_offsets);
  w->u64(r.message_index_length);
  w.str(r.compression);
  w->u64(r.compressed_size);
  w->u64(r.uncompressed_size);
}
void append(std::string& out, const Metadata& r) {
  RecordWriter w(out, Op::metadata);
  w.str(r.name);
  w.strings(r.metadata);
}
void append(std::string& out, const MetadataIndex& r) {
  RecordWriter w(out, Op::metadata_index);
  w->u64(r.offset);
  w->u64(r.length);
  w.str(r.name);
}
void append(std::string& out, const Statistics& r) {
  RecordWriter w(out, Op::statistics);
  w->u64(r.message_count);
  w->u16(r.schema_count);
  w->u32(r.channel_count);
  w->u32(r.attachment_count);
  w->u32(r.metadata_count);
  w->u32(r.chunk_count);
  w->u64(r.message_start_time);
  w->u64(r.message_end_time);
  w.offsets(r.channel_message_counts);
}
void append(std::string& out, const SummaryOffset& r) {
  RecordWriter w(out, Op::summary_offset);
  w->u8(static_cast<uint8_t>(r.group_opcode));
  w->u64(r.group_start);
  w->u64(r.group_length);
}
void append(std::string& out, const DataEnd& r) {
  RecordWriter w(out, Op::data_end);
  w->u32(r.data_section_crc);
}

Result<Header> parseHeader(std::string_view content) {
  Header r;
  FieldReader f(content, "header");
  f.str(r.profile).str(r.library);
  return f.done(std::move(r));
}
Result<Footer> parseFooter(std::string_view content) {
  Footer r;
  FieldReader f(content, "footer");
  f.num(r.summary_start).num(r.summary_offset_start).num(r.summary_crc);
  return f.done(r);
}
Result<Schema> parseSchema(std::string_view content) {
  Schema r;
  FieldReader f(content, "schema");
  f.num(r.id).str(r.name).str(r.encoding).str(r.data);
  return f.done(std::move(r));
}
Result<Channel> parseChannel(std::string_view content) {
  Channel r;
  FieldReader f(content, "channel");
  f.num(r.id).num(r.schema_id).str(r.topic).str(r.message_encoding).strings(r.metadata);
  return f.done(std::move(r));
}
Result<Message> parseMessage(std::string_view content) {
  Message r;
  FieldReader f(content, "message");
  f.num(r.channel_id).num(r.sequence).num(r.log_time).num(r.publish_time).rest(r.data);
  return f.done(r);
}
Result<Chunk> parseChunk(std::string_view content) {
  Chunk r;
  FieldReader f(content, "chunk");
  f.num(r.message_start_time).num(r.message_end_time).num(r.uncompressed_size);
  f.num(r.uncompressed_crc).str(r.compression).bytes64(r.records);
  return f.done(std::move(r));
}
Result<MessageIndex> parseMessageIndex(std::string_view content) {
  MessageIndex r;
  FieldReader f(content, "message index");
  std::string_view block;
  uint32_t n = 0;
  f.num(r.channel_id).num(n);
  if (!f.raw().view(n, block) || n % 16 != 0) f.fail();
  ByteReader in(block);
  r.records.reserve(block.size() / 16);
  while (!in.empty()) {
    uint64_t t = 0, o = 0;
    (void)in.u64(t);
    (void)in.u64(o);
    r.records.emplace_back(t, o);
  }
  return f.done(std::move(r));
}
Result<ChunkIndex> parseChunkIndex(std::string_view content) {
  ChunkIndex r;
  FieldReader f(content, "chunk index");
  f.num(r.message_start_time).num(r.message_end_time).num(r.chunk_start_offset);
  f.num(r.chunk_length).offsets(r.message_index_offsets).num(r.message_index_length);
  f.str(r.compression).num(r.compressed_size).num(r.uncompressed_size);
  return f.done(std::move(r));
}
Result<Metadata> parseMetadata(std::string_view content) {
  Metadata r;
  FieldReader f(content, "metadata");
  f.str(r.name).strings(r.metadata);
  return f.done(std::move(r));
}
Result<MetadataIndex> parseMetadataIndex(std::string_view content) {
  MetadataIndex r;
  FieldReader f(content, "metadata index");
  f.num(r.offset).num(r.length).str(r.name);
  return f.done(std::move(r));
}
Result<Statistics> parseStatistics(std::string_view content) {
  Statistics r;
  FieldReader f(content, "statistics");
  f.num(r.message_count).num(r.schema_count).num(r.channel_count).num(r.attachment_count);
  f.num(r.metadata_count).num(r.chunk_count).num(r.message_start_time).num(r.message_end_time);
  f.offsets(r.channel_message_counts);
  return f.done(std::move(r));
}
Result<SummaryOffset> parseSummaryOffset(std::string_view content) {
  SummaryOffset r;
  uint8_t op = 0;
  FieldReader f(content, "summary offset");
  f.num(op).num(r.group_start).num(r.group_length);
  r.group_opcode = static_cast<Op>(op);
  return f.done(r);
}
Result<DataEnd> parseDataEnd(std::string_view content) {
  DataEnd r;
  FieldReader f(content, "data end");
  f.num(r.data_section_crc);
  return f.done(r);
}

uint32_t crc32(std::string_view data, uint32_t crc) noexcept {
  // zlib's crc32 takes a uInt length: feed it in pieces.
  while (!data.empty()) {
    const size_t n = std::min<size_t>(data.size(), 1u << 30);
    crc = static_cast<uint32_t>(
        ::crc32(crc, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(n)));
    data.remove_prefix(n);
  }
  return crc;
}

}  // namespace skr::mcap
