// SPDX-License-Identifier: Apache-2.0
#include "device_thread.h"

#include <portaudio.h>
#include <skrobot/support/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>

namespace skr::audio {
namespace {

using Clock = std::chrono::steady_clock;

// Pa_Initialize / Pa_Terminate are process-wide and not thread-safe.
std::mutex& paMutex() {
  static std::mutex m;
  return m;
}

struct PaSession {
  PaError error;
  PaSession() {
    std::lock_guard lock(paMutex());
    error = Pa_Initialize();
  }
  ~PaSession() {
    if (error != paNoError) return;
    std::lock_guard lock(paMutex());
    Pa_Terminate();
  }
  PaSession(const PaSession&) = delete;
  PaSession& operator=(const PaSession&) = delete;
};

struct Stream {
  PaStream* s = nullptr;
  std::uint32_t rate = 0;
  std::uint16_t channels = 0;
  Stream() = default;
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  ~Stream() { close(); }
  void close() {
    if (s == nullptr) return;
    Pa_AbortStream(s);  // do not wait for queued output to drain
    Pa_CloseStream(s);
    s = nullptr;
  }
};

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The device to use, or paNoDevice; `names` lists the devices of that direction for the log.
PaDeviceIndex findDevice(const std::string& want, bool input, std::string& names) {
  PaDeviceIndex found = paNoDevice;
  const std::string needle = lower(want);
  for (PaDeviceIndex i = 0; i < Pa_GetDeviceCount(); ++i) {
    const PaDeviceInfo* d = Pa_GetDeviceInfo(i);
    if (d == nullptr || (input ? d->maxInputChannels : d->maxOutputChannels) < 1) continue;
    names += (names.empty() ? "'" : ", '") + std::string(d->name) + "'";
    if (!needle.empty() && found == paNoDevice &&
        lower(d->name).find(needle) != std::string::npos) {
      found = i;
    }
  }
  if (needle.empty()) found = input ? Pa_GetDefaultInputDevice() : Pa_GetDefaultOutputDevice();
  if (names.empty()) names = "none";
  return found;
}

std::int64_t wallNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double secondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

}  // namespace

DeviceThread::DeviceThread(plugin::Host& host, DeviceOptions options, PlayBuffer& play,
                           DeviceEvents events)
    : host_(host), options_(std::move(options)), play_(play), events_(std::move(events)) {}

DeviceThread::~DeviceThread() {
  stop();
}

void DeviceThread::start() {
  thread_ = std::thread([this] { work(); });
}

void DeviceThread::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void DeviceThread::wake() {
  cv_.notify_all();
}

void DeviceThread::work() {
  const auto& log = host_.log;
  auto idle = [&] {  // no device: wait for stop
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return stopping_; });
  };
  PaSession pa;
  if (pa.error != paNoError) {
    log.error("AUDIO-NO-DEVICE", "PortAudio could not start (", Pa_GetErrorText(pa.error),
              "): no sound, the module stays idle");
    events_.status("state", "\"no-device\"");
    return idle();
  }

  Stream in;
  if (options_.capture) {
    std::string names;
    const PaDeviceIndex dev = findDevice(options_.input_device, true, names);
    if (dev == paNoDevice) {
      log.error("AUDIO-NO-DEVICE", "no input device",
                options_.input_device.empty() ? "" : " matching '" + options_.input_device + "'",
                " (input devices: ", names, "); capture is off");
    } else {
      const PaDeviceInfo* info = Pa_GetDeviceInfo(dev);
      PaStreamParameters p{dev, 1, paInt16, info->defaultHighInputLatency, nullptr};
      const PaError e =
          Pa_OpenStream(&in.s, &p, nullptr, options_.sample_rate, options_.frame_samples,
                        paClipOff | paDitherOff, nullptr, nullptr);
      if (e != paNoError || Pa_StartStream(in.s) != paNoError) {
        log.error("AUDIO-NO-DEVICE", "cannot capture from '", info->name, "' at ",
                  options_.sample_rate, " Hz: ", Pa_GetErrorText(e), "; capture is off");
        in.close();
      } else {
        log.info("AUDIO-CAPTURE", "capturing from '", info->name, "' at ", options_.sample_rate,
                 " Hz");
        events_.status("input_device", support::jsonQuote(info->name));
      }
    }
  }
  PaDeviceIndex out_dev = paNoDevice;
  if (options_.play) {
    std::string names;
    out_dev = findDevice(options_.output_device, false, names);
    if (out_dev == paNoDevice) {
      log.error("AUDIO-NO-DEVICE", "no output device",
                options_.output_device.empty() ? "" : " matching '" + options_.output_device + "'",
                " (output devices: ", names, "); playback is off");
    } else {
      events_.status("output_device", support::jsonQuote(Pa_GetDeviceInfo(out_dev)->name));
    }
  }
  if (in.s == nullptr && out_dev == paNoDevice) {
    events_.status("state", "\"no-device\"");
    return idle();
  }
  events_.status("state", "\"running\"");

  const std::size_t frame = options_.frame_samples;
  const auto rate = static_cast<double>(options_.sample_rate);
  const Clock::time_point capture_origin = Clock::now();
  std::uint64_t captured = 0;
  Stream out;
  Clock::time_point play_origin;
  std::uint64_t played = 0;  // frames since play_origin
  std::uint64_t played_total = 0;
  bool out_failed = false;
  std::vector<std::int16_t> chunk;
  Clock::time_point last_report = Clock::now();

  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) break;
    }
    bool busy = false;
    if (in.s != nullptr) {
      const long avail = Pa_GetStreamReadAvailable(in.s);
      // A real device delivers in real time; a null one at once: never run ahead of the clock.
      const bool due = static_cast<double>(captured + frame) <=
                       secondsSince(capture_origin) * rate + static_cast<double>(frame);
      if (avail < 0) {
        log.error("AUDIO-ERROR", "capture stopped: ", Pa_GetErrorText(static_cast<PaError>(avail)));
        in.close();
      } else if (static_cast<std::size_t>(avail) >= frame && due) {
        std::vector<std::int16_t> buf(frame);
        const PaError e = Pa_ReadStream(in.s, buf.data(), static_cast<unsigned long>(frame));
        if (e != paNoError && e != paInputOverflowed) {
          log.error("AUDIO-ERROR", "capture stopped: ", Pa_GetErrorText(e));
          in.close();
        } else {
          captured += frame;
          const auto latency_ns =
              static_cast<std::int64_t>(1e9 * static_cast<double>(frame) / rate);
          events_.captured(std::move(buf), wallNs() - latency_ns);
          busy = true;
        }
      }
    }
    if (out_dev != paNoDevice && !out_failed) {
      long room = 4096;
      if (out.s != nullptr) {
        room = std::min<long>(room, Pa_GetStreamWriteAvailable(out.s));
        // Pace like capture: at most 200 ms ahead of the clock since playback (re)started.
        const double ahead = secondsSince(play_origin) * out.rate + 0.2 * out.rate;
        room = std::min<long>(room, static_cast<long>(ahead) - static_cast<long>(played));
      }
      std::uint32_t r = 0;
      std::uint16_t ch = 0;
      if (room > 0 &&
          play_.pop(chunk,
                    static_cast<std::size_t>(room) * std::max<std::uint16_t>(1, out.channels), r,
                    ch) > 0) {
        if (out.s == nullptr || r != out.rate || ch != out.channels) {
          out.close();
          const PaDeviceInfo* info = Pa_GetDeviceInfo(out_dev);
          PaStreamParameters p{out_dev, ch, paInt16, info->defaultHighOutputLatency, nullptr};
          const PaError e = Pa_OpenStream(&out.s, nullptr, &p, r, paFramesPerBufferUnspecified,
                                          paClipOff | paDitherOff, nullptr, nullptr);
          if (e != paNoError || Pa_StartStream(out.s) != paNoError) {
            log.error("AUDIO-NO-DEVICE", "cannot play on '", info->name, "' at ", r, " Hz, ", ch,
                      " channels: ", Pa_GetErrorText(e), "; playback is off");
            out.close();
            out_failed = true;
          } else {
            log.info("AUDIO-PLAY", "playing on '", info->name, "' at ", r, " Hz");
            out.rate = r;
            out.channels = ch;
            play_origin = Clock::now();
            played = 0;
          }
        }
        if (out.s != nullptr) {
          const unsigned long frames = chunk.size() / ch;
          const PaError e = Pa_WriteStream(out.s, chunk.data(), frames);
          if (e != paNoError && e != paOutputUnderflowed) {
            log.error("AUDIO-ERROR", "playback: ", Pa_GetErrorText(e));
          }
          played += frames;
          played_total += frames;
          busy = true;
        }
      } else if (out.s != nullptr && static_cast<double>(played) <
                                         secondsSince(play_origin) * out.rate - 0.5 * out.rate) {
        play_origin = Clock::now();  // starved for a while: the clock restarts with new data
        played = 0;
      }
    }
    if (secondsSince(last_report) >= 0.5) {
      last_report = Clock::now();
      events_.status("captured_samples", std::to_string(captured));
      events_.status("played_samples", std::to_string(played_total));
    }
    if (!busy) {
      std::unique_lock lock(mutex_);
      cv_.wait_for(lock, std::chrono::milliseconds(5), [&] { return stopping_; });
    }
  }
  events_.status("captured_samples", std::to_string(captured));
  events_.status("played_samples", std::to_string(played_total));
}

}  // namespace skr::audio
