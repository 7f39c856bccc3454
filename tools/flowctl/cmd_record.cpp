// SPDX-License-Identifier: Apache-2.0
// flowctl record: subscribe to streaming channels and write what they carry to an MCAP file.
//
// Threads: the satellite's loop receives (and time-stamps) messages and queues them; a disk
// thread owns the mcap::Writer, so a slow disk never blocks the flow. The queue is bounded
// (--queue-mb): past it messages are dropped and counted, never silently. Media frames of image
// channels are turned into Foxglove's image messages (JSON, base64) there too.
#include <skrobot/foxglove/images.h>
#include <skrobot/mcap/writer.h>
#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/media_frame.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

#include "mcap_mapping.h"
#include "session.h"

namespace flowctl {

namespace mcap = skr::mcap;
using skr::flow::Variant;

namespace {

// How a channel's messages are written: as they came, or as a Foxglove image message.
enum class Image { none, raw, compressed };

// What the loop hands the disk thread.
struct Item {
  enum class Kind { schema, channel, message, metadata } kind = Kind::message;
  Image image = Image::none;  // a message: converted on the disk thread
  mcap::Schema schema;
  mcap::Channel channel;
  mcap::Metadata metadata;
  uint16_t id = 0;
  uint32_t sequence = 0;
  uint64_t log_time = 0, publish_time = 0;
  std::string data;
};

class DiskThread {
 public:
  DiskThread(mcap::Writer writer, size_t queue_limit, std::chrono::milliseconds flush_every)
      : writer_(std::move(writer)), limit_(queue_limit), flush_every_(flush_every) {
    thread_ = std::thread([this] { run(); });
  }
  ~DiskThread() { (void)finish(); }
  DiskThread(const DiskThread&) = delete;
  DiskThread& operator=(const DiskThread&) = delete;
  DiskThread(DiskThread&&) = delete;
  DiskThread& operator=(DiskThread&&) = delete;

  // From the loop thread. A message is refused (false) when the queue is full.
  bool push(Item item) {
    std::lock_guard lock(m_);
    if (item.kind == Item::Kind::message && queued_ + cost(item) > limit_) return false;
    queued_ += cost(item);
    peak_ = std::max(peak_, queued_);
    q_.push_back(std::move(item));
    cv_.notify_one();
    return true;
  }
  // Writes what is queued, the summary and the footer. Idempotent; the writer's result.
  skr::Result<void> finish() {
    {
      std::lock_guard lock(m_);
      closing_ = true;
      cv_.notify_one();
    }
    if (thread_.joinable()) thread_.join();
    return result_;
  }
  [[nodiscard]] std::string failure() {
    std::lock_guard lock(m_);
    return failure_;
  }
  [[nodiscard]] size_t peakQueued() {
    std::lock_guard lock(m_);
    return peak_;
  }
  [[nodiscard]] uint64_t fileBytes() const { return file_bytes_.load(); }
  // Messages of an image channel that were not a frame of its kind (not written), by MCAP id.
  [[nodiscard]] std::map<uint16_t, uint64_t> unconverted() {
    std::lock_guard lock(m_);
    return unconverted_;
  }

 private:
  // What an item holds in memory, roughly (so that small messages count too).
  static size_t cost(const Item& item) { return sizeof(Item) + item.data.size(); }
  void run() {
    auto next_flush = std::chrono::steady_clock::now() + flush_every_;
    std::deque<Item> batch;
    bool closing = false;
    while (!closing) {
      {
        std::unique_lock lock(m_);
        cv_.wait_until(lock, next_flush, [&] { return closing_ || !q_.empty(); });
        batch.swap(q_);
        for (const auto& i : batch) queued_ -= cost(i);
        closing = closing_;
      }
      for (auto& item : batch) write(item);
      batch.clear();
      if (std::chrono::steady_clock::now() >= next_flush) {
        // A chunk at least every flush_every_: what a killed recorder loses.
        check(writer_.flushChunk());
        next_flush = std::chrono::steady_clock::now() + flush_every_;
      }
      file_bytes_ = writer_.bytesWritten();
    }
    result_ = writer_.close();
    check(result_);
    file_bytes_ = writer_.bytesWritten();
  }
  void write(Item& item) {
    switch (item.kind) {
      case Item::Kind::schema:
        return check(writer_.addSchema(std::move(item.schema)));
      case Item::Kind::channel:
        return check(writer_.addChannel(std::move(item.channel)));
      case Item::Kind::metadata:
        return check(writer_.writeMetadata(item.metadata));
      case Item::Kind::message:
        if (item.image != Image::none) {
          auto image = item.image == Image::raw
                           ? skr::foxglove::rawImage(item.data, item.channel.topic)
                           : skr::foxglove::compressedImage(item.data, item.channel.topic);
          if (!image) {
            std::lock_guard lock(m_);
            ++unconverted_[item.id];
            return;
          }
          item.data = std::move(image->json);
        }
        return check(
            writer_.write({item.id, item.sequence, item.log_time, item.publish_time, item.data}));
    }
  }
  void check(const skr::Result<void>& r) {
    if (r) return;
    std::lock_guard lock(m_);
    if (failure_.empty()) failure_ = r.error().message;
  }

  mcap::Writer writer_;
  const size_t limit_;
  const std::chrono::milliseconds flush_every_;
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<Item> q_;
  size_t queued_ = 0, peak_ = 0;
  bool closing_ = false;
  std::string failure_;
  std::map<uint16_t, uint64_t> unconverted_;
  skr::Result<void> result_;
  std::atomic<uint64_t> file_bytes_{0};
  std::thread thread_;
};

// One recorded channel: its MCAP id and what was seen.
struct Recorded {
  std::string name;
  uint16_t id = 0;
  Image image = Image::none;
  uint32_t sequence = 0;
  uint64_t messages = 0, bytes = 0, dropped = 0, unconverted = 0;
  // Media frames: the next seq expected, and frames the seq says were lost before us.
  std::optional<uint64_t> next_seq;
  uint64_t gaps = 0;
};

// Image channels (docs/recording.md): a raw `encoding` property is recorded as
// foxglove.RawImage, `jpeg` as foxglove.CompressedImage.
Image imageOf(const Variant& props) {
  const auto* map = props.asMap();
  if (map == nullptr) return Image::none;
  const auto it = map->find("encoding");
  if (it == map->end() || !it->second.isString()) return Image::none;
  const std::string& encoding = *it->second.asString();
  if (skr::foxglove::isRawImageEncoding(encoding)) return Image::raw;
  return encoding == skr::media::encodingInfo(skr::media::Format::jpeg)->encoding
             ? Image::compressed
             : Image::none;
}

}  // namespace

int cmdRecord(const Cli& cli) {
  Args args(cli.args);
  auto output = args.option("-o");
  if (!output) output = args.option("--output");
  const bool all = args.flag("--all");
  const std::string compression_name = args.option("--compression").value_or("zstd");
  const auto chunk_text = args.option("--chunk-kb");
  const auto flush_text = args.option("--flush-ms");
  const auto queue_text = args.option("--queue-mb");
  const auto duration_text = args.option("--duration");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (!output || (rest.empty() && !all) || (!rest.empty() && all)) return usageError(cli);
  auto compression = mcap::compressionFromName(compression_name == "none" ? "" : compression_name);
  if (!compression) return fail(kUsage, "--compression is zstd, lz4 or none");
  double chunk_kb = 4096, flush_ms = 1000, queue_mb = 256, duration_s = 0;
  if (chunk_text && !parseNumber(*chunk_text, "--chunk-kb", chunk_kb)) return kUsage;
  if (flush_text && !parseNumber(*flush_text, "--flush-ms", flush_ms)) return kUsage;
  if (queue_text && !parseNumber(*queue_text, "--queue-mb", queue_mb)) return kUsage;
  if (duration_text && !parseNumber(*duration_text, "--duration", duration_s)) return kUsage;
  std::vector<skr::flow::NamePattern> patterns;
  for (const auto& text : rest) {
    auto p = skr::flow::NamePattern::parse(text);
    if (!p) return fail(kUsage, "bad channel pattern '" + text + "': " + p.error().message);
    patterns.push_back(std::move(p).value());
  }
  if (all) patterns.push_back(skr::flow::NamePattern::parse("**").value());

  auto writer = mcap::Writer::create(*output, {.compression = *compression,
                                               .chunk_bytes = static_cast<size_t>(chunk_kb * 1024),
                                               .profile = std::string(mcapmap::kProfile),
                                               .library = std::string(mcapmap::kLibrary)});
  if (!writer) return fail(kFailed, writer.error().message);

  Session s(cli, 100 * skr::kNsPerMs);
  DiskThread disk(std::move(writer).value(), static_cast<size_t>(queue_mb * (1 << 20)),
                  std::chrono::milliseconds(static_cast<int64_t>(std::max(flush_ms, 1.0))));
  std::map<std::string, Recorded> recorded;  // by name + '\n' + mime
  std::map<uint16_t, Recorded*> by_hub_id;   // the hub's channel id now
  uint16_t next_id = 1;
  bool out_of_ids = false;
  // The schemas, written once each (by name, encoding and text) before the first channel that
  // uses them: Foxglove's for image channels, a typed channel's own (docs/channels.md).
  std::map<std::string, uint16_t> schema_ids;
  auto schemaId = [&](const std::string& name, const std::string& encoding,
                      const std::string& text) -> uint16_t {
    auto [it, added] = schema_ids.try_emplace(name + '\n' + encoding + '\n' + text,
                                              uint16_t(schema_ids.size() + 1));
    if (added) {
      Item item;
      item.kind = Item::Kind::schema;
      item.schema = {it->second, name, encoding, text};
      disk.push(std::move(item));
    }
    return it->second;
  };
  auto schemaFor = [&](Image image) -> uint16_t {
    if (image == Image::none) return 0;
    const bool raw = image == Image::raw;
    return schemaId(std::string(raw ? skr::foxglove::kRawImage : skr::foxglove::kCompressedImage),
                    "jsonschema",
                    raw ? skr::foxglove::rawImageSchema() : skr::foxglove::compressedImageSchema());
  };

  auto wanted = [&](const sat::ChannelInfo& info) {
    if (info.kind != uint8_t(skr::flow::ChannelKind::streaming)) return false;
    return std::any_of(patterns.begin(), patterns.end(),
                       [&](const auto& p) { return p.matches(info.name); });
  };
  auto properties = [&](const sat::ChannelInfo& info) {
    Item item;
    item.kind = Item::Kind::metadata;
    item.metadata.name = std::string(mcapmap::kPropertiesName);
    item.metadata.metadata = {
        {"channel", info.name},
        {"log_time", std::to_string(skr::realtimeNs())},
        {"properties",
         skr::flow::variantToJsonText(info.props.isMap() ? info.props : Variant::Map{})}};
    disk.push(std::move(item));
  };
  // A channel attached: its MCAP channel (once per name and mime) and its properties now.
  auto attach = [&](const sat::ChannelInfo& info) {
    if (!wanted(info)) return;
    auto [it, added] = recorded.try_emplace(info.name + "\n" + info.mime);
    Recorded& r = it->second;
    if (added) {
      if (next_id == 0) {
        out_of_ids = true;
        recorded.erase(it);
        return;
      }
      r.name = info.name;
      r.id = next_id++;
      r.image = imageOf(info.props);
      uint16_t schema = schemaFor(r.image);
      std::string encoding =
          r.image != Image::none ? std::string("json") : mcapmap::encodingForMime(info.mime);
      if (const auto type = mcapmap::typeOf(info.props);
          r.image == Image::none && mcapmap::recordedAsTyped(type)) {
        encoding = type.message_encoding;
        if (!type.schema_name.empty()) {
          schema = schemaId(type.schema_name, type.schema_encoding, type.schema);
        }
      }
      Item item;
      item.kind = Item::Kind::channel;
      item.channel = {r.id,
                      schema,
                      info.name,
                      encoding,
                      {{std::string(mcapmap::kMimeKey), info.mime},
                       {std::string(mcapmap::kOwnerKey), info.owner}}};
      disk.push(std::move(item));
    }
    by_hub_id[info.id] = &r;
    properties(info);
  };
  auto consider = [&](const sat::ChannelInfo& info) {
    if (wanted(info)) s.satellite.subscribe(info.name);
  };
  s.satellite.connected.connect(&s.satellite, [&] {
    for (const auto& info : s.satellite.channels()) consider(info);
  });
  s.satellite.channelAdded.connect(&s.satellite, consider);
  s.satellite.subscribed.connect(&s.satellite, attach);
  s.satellite.channelChanged.connect(&s.satellite, [&](const sat::ChannelInfo& info) {
    if (by_hub_id.count(info.id) != 0 && wanted(info)) properties(info);
  });
  s.satellite.channelRemoved.connect(
      &s.satellite, [&](const sat::ChannelInfo& info) { by_hub_id.erase(info.id); });
  s.satellite.dataView.connect(&s.satellite, [&](uint16_t id, std::string_view payload) {
    const auto found = by_hub_id.find(id);
    if (found == by_hub_id.end()) return;
    Recorded& r = *found->second;
    Item item;
    item.id = r.id;
    item.image = r.image;
    if (r.image != Image::none) item.channel.topic = r.name;  // the image's frame_id
    item.log_time = static_cast<uint64_t>(skr::realtimeNs());
    item.publish_time = item.log_time;
    if (auto frame = skr::media::parseFrame(payload)) {
      if (frame->header.capture_ns > 0) {
        item.publish_time = static_cast<uint64_t>(frame->header.capture_ns);
      }
      // Frames lost before they reached us (the hub drops for a slow subscriber).
      if (r.next_seq && frame->header.seq > *r.next_seq) r.gaps += frame->header.seq - *r.next_seq;
      const bool audio = frame->header.format == skr::media::Format::pcm_s16le;
      r.next_seq = frame->header.seq + (audio ? skr::media::sampleCount(*frame) : 1);
    }
    item.sequence = r.sequence++;
    item.data.assign(payload);
    if (disk.push(std::move(item))) {
      ++r.messages;
      r.bytes += payload.size();
    } else {
      ++r.dropped;
    }
  });
  const auto started = skr::monotonicNs();
  s.loop.addTickHandler(skr::Tick::slow, [&] {
    if (auto why = disk.failure(); !why.empty()) s.end(kFailed, "writing " + *output + ": " + why);
    if (duration_s > 0 &&
        skr::monotonicNs() - started >= static_cast<skr::Nanos>(duration_s * 1e9)) {
      s.loop.stop();
    }
  });
  for (const auto& p : patterns) {
    if (p.isLiteral()) s.satellite.subscribe(p.text());
  }
  std::fprintf(stderr, "flowctl: recording to %s (Ctrl-C stops)\n", output->c_str());
  int code = s.run();
  const double seconds = static_cast<double>(skr::monotonicNs() - started) / 1e9;
  if (auto r = disk.finish(); !r && code == kOk) {
    code = fail(kFailed, "closing " + *output + ": " + r.error().message);
  }
  uint64_t messages = 0, bytes = 0, dropped = 0, gaps = 0, unconverted = 0;
  const auto unconverted_by_id = disk.unconverted();
  for (auto& [key, r] : recorded) {
    if (const auto u = unconverted_by_id.find(r.id); u != unconverted_by_id.end()) {
      r.unconverted = u->second;
      r.messages -= r.unconverted;
      unconverted += r.unconverted;
    }
    messages += r.messages;
    bytes += r.bytes;
    dropped += r.dropped;
    gaps += r.gaps;
  }
  if (cli.json) {
    Variant::List channels;
    for (const auto& [key, r] : recorded) {
      channels.emplace_back(Variant::Map{{"name", r.name},
                                         {"messages", r.messages},
                                         {"bytes", r.bytes},
                                         {"dropped", r.dropped},
                                         {"unconverted", r.unconverted},
                                         {"media_gaps", r.gaps}});
    }
    std::printf("%s\n", skr::flow::variantToJsonText(
                            Variant::Map{{"file", *output},
                                         {"seconds", seconds},
                                         {"messages", messages},
                                         {"bytes", bytes},
                                         {"file_bytes", disk.fileBytes()},
                                         {"dropped", dropped},
                                         {"unconverted", unconverted},
                                         {"media_gaps", gaps},
                                         {"peak_queue_bytes", uint64_t(disk.peakQueued())},
                                         {"channels", std::move(channels)}})
                            .c_str());
  } else {
    std::printf(
        "recorded %llu messages (%llu bytes) on %zu channels in %.1f s to %s (%llu bytes)\n",
        (unsigned long long)messages, (unsigned long long)bytes, recorded.size(), seconds,
        output->c_str(), (unsigned long long)disk.fileBytes());
    for (const auto& [key, r] : recorded) {
      std::printf("  %-32s %8llu messages %12llu bytes", r.name.c_str(),
                  (unsigned long long)r.messages, (unsigned long long)r.bytes);
      if (r.dropped != 0) std::printf("  %llu DROPPED (queue full)", (unsigned long long)r.dropped);
      if (r.gaps != 0) std::printf("  %llu lost before us (seq gaps)", (unsigned long long)r.gaps);
      if (r.unconverted != 0) {
        std::printf("  %llu NOT RECORDED (not an image frame)", (unsigned long long)r.unconverted);
      }
      std::printf("\n");
    }
  }
  if (out_of_ids)
    std::fprintf(stderr, "flowctl: more than 65535 channels: the rest not recorded\n");
  if (unconverted != 0) {
    std::fprintf(stderr,
                 "flowctl: RECORD-NOT-IMAGE %llu messages of image channels were not media frames "
                 "of the channel's encoding: not recorded\n",
                 (unsigned long long)unconverted);
  }
  if (dropped != 0) {
    std::fprintf(stderr, "flowctl: %llu messages dropped: the disk did not keep up\n",
                 (unsigned long long)dropped);
  }
  return code;
}

}  // namespace flowctl
