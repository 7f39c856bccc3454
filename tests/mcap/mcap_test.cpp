// SPDX-License-Identifier: Apache-2.0
// The MCAP writer and reader (tools/mcap): round trips with each compression, files cut short,
// damaged CRCs, lengths larger than the file or the limits.
#include <gtest/gtest.h>
#include <skrobot/mcap/reader.h>
#include <skrobot/mcap/writer.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

namespace skr::mcap {
namespace {

namespace fs = std::filesystem;

struct Sent {
  uint16_t channel;
  uint64_t log_time, publish_time;
  std::string data;
};

std::string readFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

class McapTest : public ::testing::TestWithParam<Compression> {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mcap_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    path_ = (dir_ / "run.mcap").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Two channels, `count` messages, small chunks, one metadata record; closed when `close`.
  std::vector<Sent> writeSample(Compression c, int count, bool close = true) {
    auto w = Writer::create(path_, {.compression = c, .chunk_bytes = 2000});
    EXPECT_TRUE(w) << w.error().message;
    EXPECT_TRUE(w->addSchema({1, "skrobot.Text", "", ""}));
    EXPECT_TRUE(w->addChannel({1, 1, "guest.numbers", "json", {{"mime", "application/json"}}}));
    EXPECT_TRUE(w->addChannel({2, 0, "guest.camera", "image/jpeg", {}}));
    EXPECT_TRUE(w->writeMetadata({"skrobot.properties", {{"channel", "guest.camera"}}}));
    std::vector<Sent> sent;
    for (int i = 0; i < count; ++i) {
      Sent s{uint16_t(1 + i % 2), 1000u + uint64_t(i) * 10, 900u + uint64_t(i) * 10,
             i % 2 == 0 ? "{\"n\":" + std::to_string(i) + "}" : std::string(100 + i, char(i))};
      EXPECT_TRUE(w->write({s.channel, uint32_t(i), s.log_time, s.publish_time, s.data}));
      sent.push_back(std::move(s));
    }
    if (close) {
      EXPECT_TRUE(w->close());
    } else {
      EXPECT_TRUE(w->flushChunk());
    }
    return sent;
  }

  fs::path dir_;
  std::string path_;
};

TEST_P(McapTest, RoundTripIndexedAndStreaming) {
  const auto sent = writeSample(GetParam(), 200);
  auto reader = Reader::open(path_);
  ASSERT_TRUE(reader) << reader.error().message;
  auto summary = reader->readSummary();
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->header.library, "skrobot-mcap");
  ASSERT_EQ(summary->channels.size(), 2u);
  EXPECT_EQ(summary->channels.at(1).topic, "guest.numbers");
  EXPECT_EQ(summary->channels.at(1).metadata.at("mime"), "application/json");
  EXPECT_EQ(summary->schemas.at(1).name, "skrobot.Text");
  ASSERT_TRUE(summary->statistics);
  EXPECT_EQ(summary->statistics->message_count, 200u);
  EXPECT_EQ(summary->statistics->channel_message_counts.at(2), 100u);
  EXPECT_EQ(summary->statistics->message_start_time, 1000u);
  EXPECT_EQ(summary->statistics->message_end_time, 1000u + 199 * 10);
  EXPECT_GT(summary->chunks.size(), 5u);
  EXPECT_EQ(summary->statistics->chunk_count, summary->chunks.size());
  for (const auto& c : summary->chunks) {
    EXPECT_EQ(c.compression, compressionName(GetParam()));
    EXPECT_FALSE(c.message_index_offsets.empty());
  }

  std::vector<Sent> got;
  std::string buffer;
  for (const auto& c : summary->chunks) {
    auto messages = reader->readChunk(c, buffer);
    ASSERT_TRUE(messages) << messages.error().message;
    for (const auto& m : *messages) {
      got.push_back({m.channel_id, m.log_time, m.publish_time, std::string(m.data)});
    }
  }
  ASSERT_EQ(got.size(), sent.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].channel, sent[i].channel);
    EXPECT_EQ(got[i].log_time, sent[i].log_time);
    EXPECT_EQ(got[i].publish_time, sent[i].publish_time);
    EXPECT_EQ(got[i].data, sent[i].data);
  }
  ASSERT_EQ(summary->metadata.size(), 1u);
  auto meta = reader->readMetadata(summary->metadata[0]);
  ASSERT_TRUE(meta) << meta.error().message;
  EXPECT_EQ(meta->metadata.at("channel"), "guest.camera");

  size_t streamed = 0, channels = 0, metadata = 0;
  auto end = reader->scan({.channel = [&](const Channel&) { ++channels; },
                           .message =
                               [&](const Message& m) {
                                 ASSERT_LT(streamed, sent.size());
                                 EXPECT_EQ(std::string(m.data), sent[streamed].data);
                                 ++streamed;
                               },
                           .metadata = [&](const Metadata&, uint64_t) { ++metadata; }});
  ASSERT_TRUE(end) << end.error().message;
  EXPECT_TRUE(end->complete) << end->stopped;
  EXPECT_EQ(streamed, sent.size());
  EXPECT_EQ(channels, 2u);  // not the summary's copies
  EXPECT_EQ(metadata, 1u);
}

// Every cut of the file reads, streaming, as the messages of its complete chunks; never fails.
TEST_P(McapTest, CutShortReadsUpToTheLastCompleteChunk) {
  const auto sent = writeSample(GetParam(), 60);
  const std::string whole = readFile(path_);
  auto full = Reader::fromBytes(whole);
  ASSERT_TRUE(full);
  auto summary = full->readSummary();
  ASSERT_TRUE(summary);
  for (size_t cut = 0; cut < whole.size(); cut += 7) {
    const std::string_view part(whole.data(), cut);
    auto reader = Reader::fromBytes(part);
    ASSERT_TRUE(reader) << cut;
    EXPECT_FALSE(reader->readSummary()) << cut;
    size_t n = 0;
    auto end = reader->scan({.message = [&](const Message& m) {
      ASSERT_LT(n, sent.size());
      EXPECT_EQ(std::string(m.data), sent[n].data);
      ++n;
    }});
    ASSERT_TRUE(end) << "cut at " << cut << ": " << end.error().message;
    EXPECT_FALSE(end->complete);
    // The messages of the chunks that end before the cut, no more.
    size_t expected = 0;
    for (const auto& c : summary->chunks) {
      if (c.chunk_start_offset + c.chunk_length <= cut) {
        expected = 0;
        for (const auto& d : summary->chunks) {
          if (d.chunk_start_offset <= c.chunk_start_offset) {
            std::string buffer;
            expected += full->readChunk(d, buffer)->size();
          }
        }
      }
    }
    EXPECT_EQ(n, expected) << "cut at " << cut;
  }
}

// A recorder that died: chunks flushed, no summary.
TEST_P(McapTest, UnclosedWriterLeavesAStreamableFile) {
  const auto sent = writeSample(GetParam(), 40, /*close=*/false);
  auto reader = Reader::open(path_);
  ASSERT_TRUE(reader);
  EXPECT_EQ(reader->readSummary().error().code, Errc::not_found);
  size_t n = 0;
  auto end = reader->scan({.message = [&](const Message&) { ++n; }});
  ASSERT_TRUE(end);
  EXPECT_FALSE(end->complete);
  EXPECT_EQ(n, sent.size());
}

INSTANTIATE_TEST_SUITE_P(Compressions, McapTest,
                         ::testing::Values(Compression::none, Compression::zstd, Compression::lz4),
                         [](const auto& info) {
                           auto n = compressionName(info.param);
                           return n.empty() ? std::string("none") : std::string(n);
                         });

class McapDamageTest : public McapTest {};

TEST_F(McapDamageTest, ChunkCrcMismatchIsAnErrorWithItsOffset) {
  writeSample(Compression::none, 60);
  std::string bytes = readFile(path_);
  auto summary = Reader::fromBytes(bytes)->readSummary();
  ASSERT_TRUE(summary);
  ASSERT_GE(summary->chunks.size(), 2u);
  const auto& c = summary->chunks[1];
  // The last byte of the chunk's records: message data, uncompressed.
  bytes[c.chunk_start_offset + c.chunk_length - 1] ^= 0x55;
  auto reader = Reader::fromBytes(bytes);
  std::string buffer;
  auto indexed = reader->readChunk(c, buffer);
  ASSERT_FALSE(indexed);
  EXPECT_NE(indexed.error().message.find("CRC"), std::string::npos) << indexed.error().message;
  EXPECT_NE(indexed.error().message.find(std::to_string(c.chunk_start_offset)), std::string::npos);
  auto streamed = reader->scan({});
  ASSERT_FALSE(streamed);
  EXPECT_NE(streamed.error().message.find("CRC"), std::string::npos);
  // Without CRC checks the same file reads.
  auto lax = Reader::fromBytes(bytes, {.check_crcs = false});
  EXPECT_TRUE(lax->readChunk(c, buffer));
}

TEST_F(McapDamageTest, SummaryAndDataCrcMismatch) {
  writeSample(Compression::zstd, 20);
  std::string bytes = readFile(path_);
  auto summary = Reader::fromBytes(bytes)->readSummary();
  ASSERT_TRUE(summary);
  std::string damaged = bytes;
  damaged[summary->footer.summary_start + 12] ^= 1;
  auto r = Reader::fromBytes(damaged)->readSummary();
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("summary CRC"), std::string::npos) << r.error().message;
  // A metadata record's byte: covered by the data section's CRC only.
  damaged = bytes;
  damaged[summary->metadata[0].offset + summary->metadata[0].length - 1] ^= 1;
  auto s = Reader::fromBytes(damaged)->scan({});
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("data section CRC"), std::string::npos) << s.error().message;
}

// Builds a file: magic, header, then `records` (whole records), no footer.
std::string fileWith(const std::string& records) {
  std::string out(kMagic);
  append(out, Header{"", "test"});
  return out + records;
}

TEST(McapLimits, OversizedChunkIsRefusedBeforeAllocation) {
  std::string records;
  Chunk c;
  c.uncompressed_size = uint64_t{1} << 40;
  c.compression = "zstd";
  c.records = "tiny";
  append(records, c);
  const std::string bytes = fileWith(records);
  auto r = Reader::fromBytes(bytes)->scan({});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("over the limit"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("at offset 29"), std::string::npos) << r.error().message;
  // Under the limit but with an impossible ratio.
  auto small = Reader::fromBytes(bytes, {.max_chunk_bytes = uint64_t{1} << 41})->scan({});
  ASSERT_FALSE(small);
  EXPECT_NE(small.error().message.find("ratio"), std::string::npos) << small.error().message;
}

TEST(McapLimits, LengthsPastTheEnd) {
  // A record whose length runs past the file: the file was cut short, not an error.
  std::string records;
  records += char(Op::message);
  const uint64_t huge = ~uint64_t{0};
  records.append(reinterpret_cast<const char*>(&huge), 8);
  records += "abc";
  auto end = Reader::fromBytes(fileWith(records))->scan({});
  ASSERT_TRUE(end);
  EXPECT_FALSE(end->complete);
  EXPECT_NE(end->stopped.find("cut short"), std::string::npos);

  // A string length inside a record past the record: a parse error naming the offset.
  std::string bad;
  append(bad, Channel{1, 0, "topic", "json", {}});
  bad[kRecordPrefixBytes + 4] = char(0xff);  // topic length low byte
  bad[kRecordPrefixBytes + 7] = char(0x7f);  // topic length high byte
  auto r = Reader::fromBytes(fileWith(bad))->scan({});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("at offset 29"), std::string::npos) << r.error().message;

  // A chunk's record length larger than its content.
  std::string chunk;
  Chunk c;
  std::string inner;
  append(inner, Channel{1, 0, "t", "json", {}});
  inner[1] = char(0x7f);  // the inner record's length: past the chunk
  c.uncompressed_size = inner.size();
  c.records = inner;
  append(chunk, c);
  auto r2 = Reader::fromBytes(fileWith(chunk))->scan({});
  ASSERT_FALSE(r2);
  EXPECT_NE(r2.error().message.find("runs past"), std::string::npos) << r2.error().message;

  EXPECT_FALSE(Reader::fromBytes("not mcap at all"));
  EXPECT_FALSE(Reader::fromBytes(std::string_view(kMagic.data(), 5))->scan({})->complete);
}

// Random damage anywhere: an error or a short read, never a crash (the fuzz target does more).
TEST_F(McapDamageTest, RandomDamageNeverCrashes) {
  writeSample(Compression::lz4, 30);
  const std::string bytes = readFile(path_);
  std::mt19937 rng(7);
  for (int i = 0; i < 3000; ++i) {
    std::string d = bytes;
    for (int k = 0; k < 3; ++k) d[rng() % d.size()] = char(rng());
    auto reader = Reader::fromBytes(d, {.max_chunk_bytes = 1 << 20, .check_crcs = (i % 2) != 0});
    if (!reader) continue;
    (void)reader->scan({.message = [](const Message&) {}});
    if (auto s = reader->readSummary()) {
      std::string buffer;
      for (const auto& c : s->chunks) (void)reader->readChunk(c, buffer);
      for (const auto& m : s->metadata) (void)reader->readMetadata(m);
    }
  }
}

}  // namespace
}  // namespace skr::mcap
