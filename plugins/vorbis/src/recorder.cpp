// SPDX-License-Identifier: Apache-2.0
#include "recorder.h"

#include <skrobot/support/json.hpp>

#include <ctime>
#include <system_error>

namespace skr::audio {

Recorder::Recorder(plugin::Host& host, RecorderOptions options)
    : host_(host), options_(std::move(options)), queue_(options_.queue_max) {}

Recorder::~Recorder() {
  stop();
}

void Recorder::start() {
  writer_ = std::thread([this] { work(); });
  sub_ =
      plugin::Subscription(host_, options_.channel, [this](std::string_view msg) { onFrame(msg); });
  host_.log.info("VORBIS-RECORD", "recording ", options_.channel, " into ", options_.dir.string());
}

void Recorder::stop() {
  sub_.reset();
  queue_.close();  // the writer finishes the file, then exits
  if (writer_.joinable()) writer_.join();
}

void Recorder::onFrame(std::string_view msg) {
  auto chunk = input_.accept(msg);
  if (chunk && !queue_.push(std::move(*chunk))) ++dropped_;
}

std::filesystem::path Recorder::nextPath() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &tm);
  return options_.dir /
         (options_.prefix + "-" + stamp + "-" + std::to_string(++sequence_) + ".ogg");
}

// Writer thread. Drains the queue even after close() so that what was recorded is kept.
void Recorder::work() {
  OggWriter out;
  std::string current;
  auto finish = [&] {
    if (!out.isOpen()) return;
    out.close();
    host_.post([this] {
      ++files_;
      file_.clear();
    });
    host_.log.info("VORBIS-FILE", "finished ", current, ": ", out.frames(), " samples, ",
                   out.bytes(), " bytes");
  };
  auto fail = [&](const std::string& why) {
    host_.log.error("VORBIS-WRITE", why);
    host_.post([this] { ++write_errors_; });
  };
  while (auto chunk = queue_.popRemaining()) {
    const std::uint64_t frames = chunk->frames();
    const bool rotate =
        out.isOpen() &&
        (chunk->sample_rate != out.sampleRate() || chunk->channels != out.channels() ||
         (options_.rotate_bytes > 0 && out.bytes() >= options_.rotate_bytes) ||
         (options_.rotate_seconds > 0 &&
          out.frames() + frames > options_.rotate_seconds * out.sampleRate()));
    if (rotate) finish();
    if (!out.isOpen()) {
      std::error_code ec;
      std::filesystem::create_directories(options_.dir, ec);
      const auto path = nextPath();
      const std::string error =
          out.open(path, chunk->sample_rate, chunk->channels, options_.quality);
      if (!error.empty()) {
        fail(error);
        continue;  // this chunk is lost; the next one tries again
      }
      current = path.string();
      host_.post([this, name = current] { file_ = name; });
    }
    if (!out.write(chunk->samples.data(), frames)) {
      fail("writing " + current + " failed (disk full?)");
      finish();
      continue;
    }
    host_.post([this, frames] { recorded_ += frames; });
  }
  finish();
}

void Recorder::writeStats() {
  const std::string db(host_.name());
  stats_.publish(host_, input_.counters());
  plugin::dbSet(host_, db, "file", support::jsonQuote(file_));
  plugin::dbSet(host_, db, "files", std::to_string(files_));
  plugin::dbSet(host_, db, "recorded_samples", std::to_string(recorded_));
  plugin::dbSet(host_, db, "dropped", std::to_string(dropped_));
  plugin::dbSet(host_, db, "write_errors", std::to_string(write_errors_));
}

}  // namespace skr::audio
