// SPDX-License-Identifier: Apache-2.0
// The MCAP writer (writer.h).
#include <fcntl.h>
#include <skrobot/mcap/writer.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <vector>

namespace skr::mcap {

struct Writer::Impl {
  WriterOptions options;
  int fd = -1;
  uint64_t offset = 0;    // bytes in the file
  uint32_t data_crc = 0;  // of every byte before the data end record
  bool closed = false;

  std::map<uint16_t, Schema> schemas;
  std::map<uint16_t, Channel> channels;
  std::vector<ChunkIndex> chunk_indexes;
  std::vector<MetadataIndex> metadata_indexes;
  Statistics stats;

  // The chunk under way: its records uncompressed, message times and indexes.
  std::string chunk;
  uint64_t chunk_start = 0, chunk_end = 0;
  bool chunk_has_messages = false;
  std::map<uint16_t, MessageIndex> chunk_index;
  std::string compressed, out;  // reused buffers

  ~Impl() {
    if (fd >= 0) ::close(fd);
  }

  Result<void> put(std::string_view bytes, bool in_data_section = true) {
    if (in_data_section) data_crc = crc32(bytes, data_crc);
    while (!bytes.empty()) {
      const ssize_t n = ::write(fd, bytes.data(), bytes.size());
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) return makeError(Errc::io_error, std::string("write: ") + std::strerror(errno));
      bytes.remove_prefix(static_cast<size_t>(n));
      offset += static_cast<uint64_t>(n);
    }
    return {};
  }

  Result<void> flushChunk() {
    if (chunk.empty()) return {};
    if (auto r = compress(options.compression, chunk, compressed); !r) return r;
    out.clear();
    Chunk c;
    c.message_start_time = chunk_has_messages ? chunk_start : 0;
    c.message_end_time = chunk_has_messages ? chunk_end : 0;
    c.uncompressed_size = chunk.size();
    c.uncompressed_crc = crc32(chunk);
    c.compression = std::string(compressionName(options.compression));
    c.records = compressed;
    append(out, c);
    ChunkIndex ci;
    ci.message_start_time = c.message_start_time;
    ci.message_end_time = c.message_end_time;
    ci.chunk_start_offset = offset;
    ci.chunk_length = out.size();
    ci.compression = c.compression;
    ci.compressed_size = compressed.size();
    ci.uncompressed_size = chunk.size();
    for (const auto& [id, index] : chunk_index) {
      ci.message_index_offsets[id] = offset + out.size();
      append(out, index);
    }
    ci.message_index_length = out.size() - ci.chunk_length;
    if (auto r = put(out); !r) return r;
    chunk_indexes.push_back(std::move(ci));
    ++stats.chunk_count;
    chunk.clear();
    chunk_index.clear();
    chunk_has_messages = false;
    return {};
  }

  Result<void> finish() {
    if (auto r = flushChunk(); !r) return r;
    out.clear();
    append(out, DataEnd{data_crc});
    if (auto r = put(out, false); !r) return r;

    // The summary, grouped by opcode, and one summary offset per group.
    const uint64_t summary_start = offset;
    std::string summary;
    std::vector<SummaryOffset> groups;
    auto group = [&](Op op, auto&& write_records) {
      const size_t at = summary.size();
      write_records();
      if (summary.size() > at) groups.push_back({op, summary_start + at, summary.size() - at});
    };
    group(Op::schema, [&] {
      for (const auto& [id, s] : schemas) append(summary, s);
    });
    group(Op::channel, [&] {
      for (const auto& [id, c] : channels) append(summary, c);
    });
    group(Op::chunk_index, [&] {
      for (const auto& c : chunk_indexes) append(summary, c);
    });
    group(Op::metadata_index, [&] {
      for (const auto& m : metadata_indexes) append(summary, m);
    });
    group(Op::statistics, [&] {
      stats.schema_count = static_cast<uint16_t>(schemas.size());
      stats.channel_count = static_cast<uint32_t>(channels.size());
      append(summary, stats);
    });
    const uint64_t summary_offset_start = summary_start + summary.size();
    for (const auto& g : groups) append(summary, g);
    // The footer's CRC covers the summary sections and the footer up to summary_crc.
    Footer footer{summary_start, summary_offset_start, 0};
    std::string tail;
    append(tail, footer);
    footer.summary_crc = crc32(std::string_view(tail).substr(0, tail.size() - 4), crc32(summary));
    tail.clear();
    append(tail, footer);
    summary += tail;
    summary += kMagic;
    if (auto r = put(summary, false); !r) return r;
    if (::fsync(fd) != 0 && errno != EINVAL) {
      return makeError(Errc::io_error, std::string("fsync: ") + std::strerror(errno));
    }
    ::close(fd);
    fd = -1;
    return {};
  }
};

Writer::Writer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Writer::~Writer() = default;
Writer::Writer(Writer&&) noexcept = default;
Writer& Writer::operator=(Writer&&) noexcept = default;

Result<Writer> Writer::create(const std::string& path, WriterOptions options) {
  auto impl = std::make_unique<Impl>();
  impl->options = std::move(options);
  impl->fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (impl->fd < 0) {
    return makeError(Errc::io_error, "cannot create " + path + ": " + std::strerror(errno));
  }
  std::string start(kMagic);
  append(start, Header{impl->options.profile, impl->options.library});
  if (auto r = impl->put(start); !r) return r.error();
  return Writer(std::move(impl));
}

Result<void> Writer::addSchema(Schema schema) {
  if (impl_->closed) return makeError(Errc::closed, "the writer is closed");
  if (schema.id == 0) return makeError(Errc::invalid_argument, "schema id 0 is reserved");
  append(impl_->chunk, schema);
  impl_->schemas[schema.id] = std::move(schema);
  return {};
}

Result<void> Writer::addChannel(Channel channel) {
  if (impl_->closed) return makeError(Errc::closed, "the writer is closed");
  if (channel.schema_id != 0 && impl_->schemas.count(channel.schema_id) == 0) {
    return makeError(Errc::not_found, "no schema " + std::to_string(channel.schema_id));
  }
  append(impl_->chunk, channel);
  impl_->channels[channel.id] = std::move(channel);
  return {};
}

Result<void> Writer::write(const Message& m) {
  auto& d = *impl_;
  if (d.closed) return makeError(Errc::closed, "the writer is closed");
  if (d.channels.count(m.channel_id) == 0) {
    return makeError(Errc::not_found, "no channel " + std::to_string(m.channel_id));
  }
  auto& index = d.chunk_index[m.channel_id];
  index.channel_id = m.channel_id;
  index.records.emplace_back(m.log_time, d.chunk.size());
  append(d.chunk, m);
  if (!d.chunk_has_messages) {
    d.chunk_start = d.chunk_end = m.log_time;
    d.chunk_has_messages = true;
  }
  d.chunk_start = std::min(d.chunk_start, m.log_time);
  d.chunk_end = std::max(d.chunk_end, m.log_time);
  auto& s = d.stats;
  s.message_start_time =
      s.message_count == 0 ? m.log_time : std::min(s.message_start_time, m.log_time);
  s.message_end_time = std::max(s.message_end_time, m.log_time);
  ++s.message_count;
  ++s.channel_message_counts[m.channel_id];
  if (d.chunk.size() >= d.options.chunk_bytes) return d.flushChunk();
  return {};
}

Result<void> Writer::writeMetadata(const Metadata& metadata) {
  auto& d = *impl_;
  if (d.closed) return makeError(Errc::closed, "the writer is closed");
  d.out.clear();
  append(d.out, metadata);
  MetadataIndex index{d.offset, d.out.size(), metadata.name};
  if (auto r = d.put(d.out); !r) return r;
  d.metadata_indexes.push_back(std::move(index));
  ++d.stats.metadata_count;
  return {};
}

Result<void> Writer::flushChunk() {
  if (impl_->closed) return makeError(Errc::closed, "the writer is closed");
  return impl_->flushChunk();
}

Result<void> Writer::close() {
  if (impl_->closed) return makeError(Errc::closed, "the writer is closed");
  impl_->closed = true;
  return impl_->finish();
}

uint64_t Writer::bytesWritten() const noexcept {
  return impl_->offset;
}
const Statistics& Writer::statistics() const noexcept {
  return impl_->stats;
}

}  // namespace skr::mcap
