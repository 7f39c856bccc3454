// SPDX-License-Identifier: Apache-2.0
// An MCAP writer: messages in compressed chunks, each followed by its message indexes; on close,
// the data end, the summary (schemas, channels, chunk indexes, metadata indexes, statistics),
// the summary offsets and the footer.
//
// Crash behaviour: a chunk and its message indexes go to the file with one write() when the
// chunk is full or flushChunk() is called, and metadata records at once, so a process killed
// at any moment leaves a file that streaming readers read up to its last complete chunk.
//
// Not thread-safe: one thread owns a Writer. It blocks on the disk.
#pragma once

#include <skrobot/mcap/compression.h>
#include <skrobot/mcap/records.h>

#include <memory>
#include <string>
#include <string_view>

namespace skr::mcap {

struct WriterOptions {
  Compression compression = Compression::zstd;
  size_t chunk_bytes = 4u << 20;  // a chunk is written when its records reach this size
  std::string profile = {};       // the header's profile ("" : none)
  std::string library = "skrobot-mcap";
};

class Writer {
 public:
  // Creates (truncates) `path` and writes the magic and header. Errc::io_error.
  [[nodiscard]] static Result<Writer> create(const std::string& path, WriterOptions options);
  ~Writer();  // closes the file without a summary when close() was not called (as a crash would)
  Writer(Writer&&) noexcept;
  Writer& operator=(Writer&&) noexcept;
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // Ids are the caller's; schema ids are not 0. A schema or channel is written into the chunk
  // under way (so it precedes its messages) and into the summary at close().
  [[nodiscard]] Result<void> addSchema(Schema schema);
  [[nodiscard]] Result<void> addChannel(Channel channel);
  // Errc::not_found for an unknown channel id.
  [[nodiscard]] Result<void> write(const Message& message);
  // Written at once, between chunks (the chunk under way follows it).
  [[nodiscard]] Result<void> writeMetadata(const Metadata& metadata);
  // Writes the chunk under way, if it holds anything.
  [[nodiscard]] Result<void> flushChunk();
  // Flushes, then writes data end, summary and footer, and closes the file. Once.
  [[nodiscard]] Result<void> close();

  [[nodiscard]] uint64_t bytesWritten() const noexcept;  // the file's size so far
  [[nodiscard]] const Statistics& statistics() const noexcept;

 private:
  struct Impl;
  explicit Writer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace skr::mcap
