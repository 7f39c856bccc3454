// SPDX-License-Identifier: Apache-2.0
// MCAP records (https://mcap.dev/spec, major version 0): opcodes, the records this library reads
// and writes, and their byte encoding. All integers little-endian; strings, byte arrays and maps
// carry a u32 byte length (the chunk's records and an attachment's data a u64 one).
#pragma once

#include <skrobot/result.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skr::mcap {

// The file starts and ends with these 8 bytes ("MCAP" and the major version '0').
inline constexpr std::string_view kMagic{"\x89MCAP0\r\n", 8};
// A record's opcode (1 byte) and content length (u64).
inline constexpr size_t kRecordPrefixBytes = 9;
// Footer content: summary_start, summary_offset_start, summary_crc.
inline constexpr size_t kFooterContentBytes = 20;

enum class Op : uint8_t {
  header = 0x01,
  footer = 0x02,
  schema = 0x03,
  channel = 0x04,
  message = 0x05,
  chunk = 0x06,
  message_index = 0x07,
  chunk_index = 0x08,
  attachment = 0x09,
  attachment_index = 0x0a,
  statistics = 0x0b,
  metadata = 0x0c,
  metadata_index = 0x0d,
  summary_offset = 0x0e,
  data_end = 0x0f,
};

using StringMap = std::map<std::string, std::string>;

struct Header {
  std::string profile;
  std::string library;
};
struct Footer {
  uint64_t summary_start = 0;         // 0: no summary section
  uint64_t summary_offset_start = 0;  // 0: no summary offset section
  uint32_t summary_crc = 0;           // 0: not available
};
struct Schema {
  uint16_t id = 0;  // never 0
  std::string name;
  std::string encoding;
  std::string data;
};
struct Channel {
  uint16_t id = 0;
  uint16_t schema_id = 0;  // 0: no schema
  std::string topic;
  std::string message_encoding;
  StringMap metadata;
};
// A message as read: `data` points into the file or a decompressed chunk.
struct Message {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time = 0;      // ns
  uint64_t publish_time = 0;  // ns
  std::string_view data;
};
struct Chunk {
  uint64_t message_start_time = 0;
  uint64_t message_end_time = 0;
  uint64_t uncompressed_size = 0;
  uint32_t uncompressed_crc = 0;  // 0: not checked
  std::string compression;        // "", "zstd" or "lz4"
  std::string_view records;       // compressed
};
struct MessageIndex {
  uint16_t channel_id = 0;
  std::vector<std::pair<uint64_t, uint64_t>> records;  // log_time, offset in the chunk's records
};
struct ChunkIndex {
  uint64_t message_start_time = 0;
  uint64_t message_end_time = 0;
  uint64_t chunk_start_offset = 0;
  uint64_t chunk_length = 0;  // the whole record, prefix included
  std::map<uint16_t, uint64_t> message_index_offsets;
  uint64_t message_index_length = 0;
  std::string compression;
  uint64_t compressed_size = 0;
  uint64_t uncompressed_size = 0;
};
struct Metadata {
  std::string name;
  StringMap metadata;
};
struct MetadataIndex {
  uint64_t offset = 0;
  uint64_t length = 0;
  std::string name;
};
struct Statistics {
  uint64_t message_count = 0;
  uint16_t schema_count = 0;
  uint32_t channel_count = 0;
  uint32_t attachment_count = 0;
  uint32_t metadata_count = 0;
  uint32_t chunk_count = 0;
  uint64_t message_start_time = 0;
  uint64_t message_end_time = 0;
  std::map<uint16_t, uint64_t> channel_message_counts;
};
struct SummaryOffset {
  Op group_opcode = Op::header;
  uint64_t group_start = 0;
  uint64_t group_length = 0;
};
struct DataEnd {
  uint32_t data_section_crc = 0;
};

// Appends one whole record (opcode, length, content) to `out`.
void append(std::string& out, const Header& r);
void append(std::string& out, const Footer& r);
void append(std::string& out, const Schema& r);
void append(std::string& out, const Channel& r);
void append(std::string& out, const Message& r);
void append(std::string& out, const Chunk& r);
void append(std::string& out, const MessageIndex& r);
void append(std::string& out, const ChunkIndex& r);
void append(std::string& out, const Metadata& r);
void append(std::string& out, const MetadataIndex& r);
void append(std::string& out, const Statistics& r);
void append(std::string& out, const SummaryOffset& r);
void append(std::string& out, const DataEnd& r);

// Parse one record's content (without the opcode and length). Fields past the known ones are
// ignored (the spec lets records grow); a content shorter than its fields is Errc::parse_error.
// Views (Message::data, Chunk::records) point into `content`.
[[nodiscard]] Result<Header> parseHeader(std::string_view content);
[[nodiscard]] Result<Footer> parseFooter(std::string_view content);
[[nodiscard]] Result<Schema> parseSchema(std::string_view content);
[[nodiscard]] Result<Channel> parseChannel(std::string_view content);
[[nodiscard]] Result<Message> parseMessage(std::string_view content);
[[nodiscard]] Result<Chunk> parseChunk(std::string_view content);
[[nodiscard]] Result<MessageIndex> parseMessageIndex(std::string_view content);
[[nodiscard]] Result<ChunkIndex> parseChunkIndex(std::string_view content);
[[nodiscard]] Result<Metadata> parseMetadata(std::string_view content);
[[nodiscard]] Result<MetadataIndex> parseMetadataIndex(std::string_view content);
[[nodiscard]] Result<Statistics> parseStatistics(std::string_view content);
[[nodiscard]] Result<SummaryOffset> parseSummaryOffset(std::string_view content);
[[nodiscard]] Result<DataEnd> parseDataEnd(std::string_view content);

// CRC-32 (ISO-HDLC, as zlib computes it), continued from `crc` (0 to start).
[[nodiscard]] uint32_t crc32(std::string_view data, uint32_t crc = 0) noexcept;

}  // namespace skr::mcap
