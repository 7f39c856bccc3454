// SPDX-License-Identifier: Apache-2.0
// Records an audio channel to Ogg Vorbis files, rotating by size or by audio duration.
// The loop thread parses frames and queues them (never blocks); a writer thread encodes and
// writes, and posts progress back. The module's database gets: "file" (the file being written),
// "files" (files finished), "recorded_samples", "dropped" (chunks lost to a full queue),
// "write_errors", and the input counters (frames, malformed, gaps, gap_samples, ...).
#pragma once

#include <skrobot/audio/bounded_queue.h>
#include <skrobot/audio/input_stats.h>
#include <skrobot/audio/pcm_input.h>
#include "ogg_writer.h"

#include <skrobot/plugin_channels.hpp>

#include <filesystem>
#include <string>
#include <thread>

namespace skr::audio {

struct RecorderOptions {
  std::string channel;  // full name of the audio channel
  std::filesystem::path dir;
  std::string prefix;
  std::uint64_t rotate_bytes = 0;    // 0: no rotation by size
  std::uint64_t rotate_seconds = 0;  // 0: no rotation by duration (seconds of audio)
  float quality = 0.4f;
  std::size_t queue_max = 256;
};

class Recorder {
 public:
  Recorder(plugin::Host& host, RecorderOptions options);
  ~Recorder();  // stop()
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  Recorder(Recorder&&) = delete;
  Recorder& operator=(Recorder&&) = delete;

  void start();  // loop thread: subscribes and starts the writer
  void stop();   // loop thread: unsubscribes, finishes the file, joins the writer
  void writeStats();

 private:
  void onFrame(std::string_view msg);
  void work();
  std::filesystem::path nextPath();

  plugin::Host& host_;
  RecorderOptions options_;
  BoundedQueue<PcmChunk> queue_;
  PcmInput input_;
  InputStats stats_;
  plugin::Subscription sub_;
  std::thread writer_;
  // Loop-thread state, updated by posts from the writer.
  std::string file_;
  std::uint64_t files_ = 0;
  std::uint64_t recorded_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint64_t write_errors_ = 0;
  // Writer-thread state.
  std::uint64_t sequence_ = 0;
};

}  // namespace skr::audio
