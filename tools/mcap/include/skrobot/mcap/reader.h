// SPDX-License-Identifier: Apache-2.0
// An MCAP reader: indexed (footer, summary, then chunks by their index) or streaming (every
// record from the start, which also reads a file cut short up to its last complete record).
//
// Every length read from the file is checked against what is left of the file, and a chunk's
// uncompressed size against ReaderOptions::max_chunk_bytes, before anything is allocated. A
// malformed file gives Errc::parse_error whose message names the offset; never a crash.
#pragma once

#include <skrobot/mcap/compression.h>
#include <skrobot/mcap/records.h>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::mcap {

struct ReaderOptions {
  uint64_t max_chunk_bytes = 256u << 20;  // a bigger uncompressed chunk is refused
  bool check_crcs = true;                 // chunk, data section and summary CRCs (when not 0)
};

// What the indexed reader finds at the end of the file.
struct Summary {
  Header header;
  Footer footer;
  std::map<uint16_t, Schema> schemas;
  std::map<uint16_t, Channel> channels;
  std::vector<ChunkIndex> chunks;  // in file order
  std::vector<MetadataIndex> metadata;
  std::optional<Statistics> statistics;
};

// The streaming reader's callbacks, each optional; in file order. Schema and channel records are
// given once (the summary's copies are not). `offset` is the record's place in the file (for a
// record inside a chunk: the chunk's).
struct Visitor {
  std::function<void(const Header&)> header = {};
  std::function<void(const Schema&)> schema = {};
  std::function<void(const Channel&)> channel = {};
  std::function<void(const Message&)> message = {};
  std::function<void(const Metadata&, uint64_t offset)> metadata = {};
};

// Where a streaming read ended.
struct ScanEnd {
  bool complete = false;     // the footer and the closing magic were read
  uint64_t valid_bytes = 0;  // the end of the last complete record
  std::string stopped;       // why it ended early (a file cut short), else empty
};

class Reader {
 public:
  // Maps the file. Errc::io_error, Errc::parse_error (not an MCAP file).
  [[nodiscard]] static Result<Reader> open(const std::string& path, ReaderOptions options = {});
  // Reads `bytes`, which the caller keeps alive as long as the Reader.
  [[nodiscard]] static Result<Reader> fromBytes(std::string_view bytes, ReaderOptions options = {});
  ~Reader();
  Reader(Reader&&) noexcept;
  Reader& operator=(Reader&&) noexcept;
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  [[nodiscard]] std::string_view bytes() const noexcept;

  // Indexed: the footer and summary. Errc::not_found when the file has no footer or no summary
  // (a file cut short: use scan()).
  [[nodiscard]] Result<Summary> readSummary() const;
  // The messages of one chunk, sorted by log time (stable); `buffer` holds the decompressed
  // records the messages point into.
  [[nodiscard]] Result<std::vector<Message>> readChunk(const ChunkIndex& index,
                                                       std::string& buffer) const;
  [[nodiscard]] Result<Metadata> readMetadata(const MetadataIndex& index) const;

  // Streaming: every record from the start. A file that ends early (no footer, or a record cut
  // short) is not an error: the ScanEnd says where it stopped. A damaged record is.
  [[nodiscard]] Result<ScanEnd> scan(const Visitor& visitor) const;

 private:
  struct Impl;
  explicit Reader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace skr::mcap
