// SPDX-License-Identifier: Apache-2.0
// Plays an Ogg Vorbis file onto <module>.playback as PCM media frames, paced to real time with a
// small lead (consumers buffer by the sample counter). A decoder thread reads and paces; the loop
// thread publishes. Playback starts with the first subscriber, pauses when the last one leaves
// and resumes where it was; at the end of the file it loops or stops ("playing" false in the
// module's database, with "played_samples").
#pragma once

#include "ogg_reader.h"

#include <skrobot/plugin_channels.hpp>

#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

namespace skr::audio {

struct PlayerOptions {
  std::filesystem::path file;
  bool loop = false;
  std::int64_t lead_ms = 300;  // how far ahead of real time frames are published
  std::size_t frame_samples = 1024;
};

class Player {
 public:
  Player(plugin::Host& host, PlayerOptions options);
  ~Player();  // stop()
  Player(const Player&) = delete;
  Player& operator=(const Player&) = delete;
  Player(Player&&) = delete;
  Player& operator=(Player&&) = delete;

  // Loop thread: opens the file (headers only) and creates <module>.playback. Throws
  // plugin::Failure when the file cannot be read.
  void start();
  void stop();  // loop thread: joins the decoder

 private:
  void setListening(bool listening);
  void work();

  plugin::Host& host_;
  PlayerOptions options_;
  OggReader reader_;  // the decoder thread's once started
  plugin::StreamChannel out_;
  std::thread decoder_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool listening_ = false;    // guarded by mutex_
  bool stopping_ = false;     // guarded by mutex_
  std::uint64_t played_ = 0;  // loop thread
};

}  // namespace skr::audio
