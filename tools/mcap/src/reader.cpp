// SPDX-License-Identifier: Apache-2.0
// The MCAP reader (reader.h).
#include <fcntl.h>
#include <skrobot/mcap/reader.h>
#include <skrobot/runtime/flow/bytes.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace skr::mcap {

namespace {

Error malformed(uint64_t offset, const std::string& what) {
  return makeError(Errc::parse_error, "at offset " + std::to_string(offset) + ": " + what);
}

// One record's opcode and content, read at `pos` of `bytes`.
struct Record {
  Op op = Op::header;
  std::string_view content;
  uint64_t size = 0;  // prefix included
};

// False when the record does not fit in what is left (a file or chunk cut short).
bool recordAt(std::string_view bytes, uint64_t pos, Record& out) {
  if (pos > bytes.size() || bytes.size() - pos < kRecordPrefixBytes) return false;
  flow::ByteReader r(bytes.substr(pos));
  uint8_t op = 0;
  uint64_t length = 0;
  (void)r.u8(op);
  (void)r.u64(length);
  if (length > r.remaining()) return false;
  out.op = static_cast<Op>(op);
  out.content = bytes.substr(pos + kRecordPrefixBytes, length);
  out.size = kRecordPrefixBytes + length;
  return true;
}

// Adds `at` to a parse error's message.
template <typename T>
Result<T> located(Result<T> r, uint64_t at) {
  if (r) return r;
  return malformed(at, r.error().message);
}

}  // namespace

struct Reader::Impl {
  ReaderOptions options;
  std::string_view bytes;
  void* map = nullptr;
  size_t map_size = 0;

  ~Impl() {
    if (map != nullptr) ::munmap(map, map_size);
  }

  // Decompresses a chunk (at file offset `at`) into `buffer` and checks its CRC.
  Result<void> decode(const Chunk& c, uint64_t at, std::string& buffer) const {
    auto kind = compressionFromName(c.compression);
    if (!kind) return malformed(at, kind.error().message);
    if (c.uncompressed_size > options.max_chunk_bytes) {
      return malformed(at, "chunk of " + std::to_string(c.uncompressed_size) +
                               " bytes uncompressed, over the limit of " +
                               std::to_string(options.max_chunk_bytes));
    }
    // No codec expands data more than ~65000 times (zstd's bound), lz4 about 255 times.
    if (*kind != Compression::none && c.uncompressed_size / 70000 > c.records.size()) {
      return malformed(at, "chunk claims an impossible compression ratio");
    }
    if (auto r = decompress(*kind, c.records, c.uncompressed_size, buffer); !r) {
      return malformed(at, r.error().message);
    }
    if (options.check_crcs && c.uncompressed_crc != 0 && crc32(buffer) != c.uncompressed_crc) {
      return malformed(at, "chunk CRC mismatch");
    }
    return {};
  }

  // The records of a decompressed chunk.
  template <typename Fn>
  Result<void> eachInChunk(std::string_view records, uint64_t at, Fn&& fn) const {
    uint64_t pos = 0;
    while (pos < records.size()) {
      Record rec;
      if (!recordAt(records, pos, rec)) {
        return malformed(at,
                         "record at " + std::to_string(pos) + " of the chunk runs past its end");
      }
      if (rec.op == Op{0}) return malformed(at, "opcode 0 in a chunk");
      if (auto r = fn(rec, pos); !r) return r;
      pos += rec.size;
    }
    return {};
  }
};

Reader::Reader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Reader::~Reader() = default;
Reader::Reader(Reader&&) noexcept = default;
Reader& Reader::operator=(Reader&&) noexcept = default;

std::string_view Reader::bytes() const noexcept {
  return impl_->bytes;
}

Result<Reader> Reader::fromBytes(std::string_view bytes, ReaderOptions options) {
  if (bytes.size() < kMagic.size() ? !kMagic.starts_with(bytes) : !bytes.starts_with(kMagic)) {
    return makeError(Errc::parse_error, "not an MCAP file (no magic at offset 0)");
  }
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->bytes = bytes;
  return Reader(std::move(impl));
}

Result<Reader> Reader::open(const std::string& path, ReaderOptions options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return makeError(Errc::io_error, "cannot open " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    return makeError(Errc::io_error, "cannot stat " + path);
  }
  const auto size = static_cast<size_t>(st.st_size);
  void* map = nullptr;
  if (size > 0) {
    map = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (map == MAP_FAILED) {
      ::close(fd);
      return makeError(Errc::io_error, "cannot map " + path + ": " + std::strerror(errno));
    }
  }
  ::close(fd);
  auto reader = fromBytes(std::string_view(static_cast<const char*>(map), size), options);
  if (!reader) {
    if (map != nullptr) ::munmap(map, size);
    return makeError(Errc::parse_error, path + ": " + reader.error().message);
  }
  reader->impl_->map = map;
  reader->impl_->map_size = size;
  return reader;
}

Result<Summary> Reader::readSummary() const {
  const auto bytes = impl_->bytes;
  const uint64_t tail = kRecordPrefixBytes + kFooterContentBytes + kMagic.size();
  if (bytes.size() < kMagic.size() + tail || !bytes.ends_with(kMagic)) {
    return makeError(Errc::not_found, "no footer: the file was cut short (read it streaming)");
  }
  const uint64_t footer_at = bytes.size() - tail;
  Record rec;
  if (!recordAt(bytes, footer_at, rec) || rec.op != Op::footer ||
      rec.content.size() != kFooterContentBytes) {
    return malformed(footer_at, "no footer record before the closing magic");
  }
  Summary s;
  auto footer = located(parseFooter(rec.content), footer_at);
  if (!footer) return footer.error();
  s.footer = *footer;
  Record first;
  if (recordAt(bytes, kMagic.size(), first) && first.op == Op::header) {
    if (auto h = parseHeader(first.content)) s.header = *h;
  }
  if (s.footer.summary_start == 0) {
    return makeError(Errc::not_found, "the file has no summary section");
  }
  const uint64_t summary_end =
      s.footer.summary_offset_start != 0 ? s.footer.summary_offset_start : footer_at;
  if (s.footer.summary_start < kMagic.size() || s.footer.summary_start > summary_end ||
      summary_end > footer_at) {
    return malformed(footer_at, "footer points outside the file");
  }
  if (impl_->options.check_crcs && s.footer.summary_crc != 0) {
    const auto covered = bytes.substr(s.footer.summary_start,
                                      footer_at + kRecordPrefixBytes + 16 - s.footer.summary_start);
    if (crc32(covered) != s.footer.summary_crc) return malformed(footer_at, "summary CRC mismatch");
  }
  for (uint64_t pos = s.footer.summary_start; pos < summary_end; pos += rec.size) {
    if (!recordAt(bytes.substr(0, summary_end), pos, rec)) {
      return malformed(pos, "summary record runs past the summary");
    }
    if (rec.op == Op{0}) return malformed(pos, "opcode 0");
    switch (rec.op) {
      case Op::schema: {
        auto r = located(parseSchema(rec.content), pos);
        if (!r) return r.error();
        s.schemas[r->id] = std::move(r).value();
        break;
      }
      case Op::channel: {
        auto r = located(parseChannel(rec.content), pos);
        if (!r) return r.error();
        s.channels[r->id] = std::move(r).value();
        break;
      }
      case Op::chunk_index: {
        auto r = located(parseChunkIndex(rec.content), pos);
        if (!r) return r.error();
        if (r->chunk_start_offset > bytes.size() ||
            r->chunk_length > bytes.size() - r->chunk_start_offset) {
          return malformed(pos, "chunk index points outside the file");
        }
        s.chunks.push_back(std::move(r).value());
        break;
      }
      case Op::metadata_index: {
        auto r = located(parseMetadataIndex(rec.content), pos);
        if (!r) return r.error();
        s.metadata.push_back(std::move(r).value());
        break;
      }
      case Op::statistics: {
        auto r = located(parseStatistics(rec.content), pos);
        if (!r) return r.error();
        s.statistics = std::move(r).value();
        break;
      }
      default:
        break;  // attachment indexes, private records: not used here
    }
  }
  return s;
}

Result<std::vector<Message>> Reader::readChunk(const ChunkIndex& index, std::string& buffer) const {
  const auto bytes = impl_->bytes;
  const uint64_t at = index.chunk_start_offset;
  Record rec;
  if (at > bytes.size() || index.chunk_length > bytes.size() - at ||
      !recordAt(bytes.substr(0, at + index.chunk_length), at, rec) || rec.op != Op::chunk) {
    return malformed(at, "no chunk where the chunk index points");
  }
  auto chunk = located(parseChunk(rec.content), at);
  if (!chunk) return chunk.error();
  if (auto r = impl_->decode(*chunk, at, buffer); !r) return r.error();
  std::vector<Message> messages;
  auto r = impl_->eachInChunk(buffer, at, [&](const Record& inner, uint64_t) -> Result<void> {
    if (inner.op != Op::message) return {};
    auto m = located(parseMessage(inner.content), at);
    if (!m) return m.error();
    messages.push_back(*m);
    return {};
  });
  if (!r) return r.error();
  std::stable_sort(messages.begin(), messages.end(),
                   [](const Message& a, const Message& b) { return a.log_time < b.log_time; });
  return messages;
}

Result<Metadata> Reader::readMetadata(const MetadataIndex& index) const {
  const auto bytes = impl_->bytes;
  Record rec;
  if (index.offset > bytes.size() || index.length > bytes.size() - index.offset ||
      !recordAt(bytes.substr(0, index.offset + index.length), index.offset, rec) ||
      rec.op != Op::metadata) {
    return malformed(index.offset, "no metadata where the metadata index points");
  }
  return located(parseMetadata(rec.content), index.offset);
}

Result<ScanEnd> Reader::scan(const Visitor& v) const {
  const auto bytes = impl_->bytes;
  ScanEnd end;
  end.valid_bytes = std::min<uint64_t>(bytes.size(), kMagic.size());
  if (bytes.size() < kMagic.size()) {
    end.stopped = "the file ends inside its magic";
    return end;
  }
  bool summary = false;  // after the data end: channels and schemas are copies
  std::string buffer;
  uint64_t pos = kMagic.size();
  auto message = [&](std::string_view content, uint64_t at) -> Result<void> {
    auto m = located(parseMessage(content), at);
    if (!m) return m.error();
    if (v.message) v.message(*m);
    return {};
  };
  auto definition = [&](const Record& rec, uint64_t at) -> Result<void> {
    if (rec.op == Op::schema) {
      auto s = located(parseSchema(rec.content), at);
      if (!s) return s.error();
      if (v.schema && !summary) v.schema(*s);
    } else if (rec.op == Op::channel) {
      auto c = located(parseChannel(rec.content), at);
      if (!c) return c.error();
      if (v.channel && !summary) v.channel(*c);
    }
    return {};
  };
  while (true) {
    Record rec;
    if (!recordAt(bytes, pos, rec)) {
      end.stopped = pos == bytes.size()
                        ? "the file ends at offset " + std::to_string(pos) + " without a footer"
                        : "the record at offset " + std::to_string(pos) + " is cut short";
      return end;
    }
    if (rec.op == Op{0}) return malformed(pos, "opcode 0");
    switch (rec.op) {
      case Op::header: {
        if (pos != kMagic.size()) return malformed(pos, "a second header");
        auto h = located(parseHeader(rec.content), pos);
        if (!h) return h.error();
        if (v.header) v.header(*h);
        break;
      }
      case Op::schema:
      case Op::channel:
        if (auto r = definition(rec, pos); !r) return r.error();
        break;
      case Op::message:
        if (auto r = message(rec.content, pos); !r) return r.error();
        break;
      case Op::chunk: {
        auto c = located(parseChunk(rec.content), pos);
        if (!c) return c.error();
        if (auto r = impl_->decode(*c, pos, buffer); !r) return r.error();
        const uint64_t at = pos;
        auto r = impl_->eachInChunk(buffer, pos, [&](const Record& inner, uint64_t) {
          return inner.op == Op::message ? message(inner.content, at) : definition(inner, at);
        });
        if (!r) return r.error();
        break;
      }
      case Op::metadata: {
        auto m = located(parseMetadata(rec.content), pos);
        if (!m) return m.error();
        if (v.metadata) v.metadata(*m, pos);
        break;
      }
      case Op::data_end: {
        auto d = located(parseDataEnd(rec.content), pos);
        if (!d) return d.error();
        if (impl_->options.check_crcs && d->data_section_crc != 0 &&
            crc32(bytes.substr(0, pos)) != d->data_section_crc) {
          return malformed(pos, "data section CRC mismatch");
        }
        summary = true;
        break;
      }
      case Op::footer: {
        end.valid_bytes = pos + rec.size;
        if (bytes.substr(pos + rec.size) != kMagic) {
          if (kMagic.starts_with(bytes.substr(pos + rec.size))) {
            end.stopped = "the file ends inside its closing magic";
            return end;
          }
          return malformed(pos + rec.size, "no closing magic after the footer");
        }
        end.valid_bytes = bytes.size();
        end.complete = true;
        return end;
      }
      default:
        break;  // indexes, statistics, attachments, private records
    }
    pos += rec.size;
    end.valid_bytes = pos;
  }
}

}  // namespace skr::mcap
