// SPDX-License-Identifier: Apache-2.0
// The PortAudio side of audio-io: one thread that initialises PortAudio, opens the input and
// output devices with the blocking API, captures fixed-size frames and plays what PlayBuffer
// holds. It never calls the hub except through Host::post and logging. Devices that deliver or
// accept faster than their sample rate (ALSA's null device) are paced to the wall clock.
#pragma once

#include "play_buffer.h"

#include <skrobot/plugin.hpp>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace skr::audio {

struct DeviceOptions {
  bool capture = true;
  std::string input_device;  // "" = the default input; else a case-insensitive part of a name
  bool play = false;
  std::string output_device;
  std::uint32_t sample_rate = 22050;  // capture rate; playback follows the played channel
  std::size_t frame_samples = 1024;   // per captured frame
};

struct DeviceEvents {
  // Device thread -> (the module posts them to the loop thread)
  std::function<void(std::vector<std::int16_t> samples, std::int64_t capture_ns)> captured;
  std::function<void(const std::string& key, const std::string& value_json)> status;
};

class DeviceThread {
 public:
  DeviceThread(plugin::Host& host, DeviceOptions options, PlayBuffer& play, DeviceEvents events);
  ~DeviceThread();  // stop()
  DeviceThread(const DeviceThread&) = delete;
  DeviceThread& operator=(const DeviceThread&) = delete;
  DeviceThread(DeviceThread&&) = delete;
  DeviceThread& operator=(DeviceThread&&) = delete;

  void start();
  void stop();  // joins; the streams are closed and PortAudio terminated by then
  void wake();  // new samples to play

 private:
  void work();

  plugin::Host& host_;
  DeviceOptions options_;
  PlayBuffer& play_;
  DeviceEvents events_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
};

}  // namespace skr::audio
