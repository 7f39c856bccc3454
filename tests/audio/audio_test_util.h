// SPDX-License-Identifier: Apache-2.0
// Helpers for the audio module tests: PCM frames of generated signals, a satellite that listens
// to several channels, module database reads, and a plain DFT to check spectra independently of
// the modules' FFTW code.
#pragma once

#include "module_fixture.h"

#include <skrobot/media_frame.hpp>

#include <json/json.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace skr::test::audio {

inline constexpr uint32_t kRate = 22050;
// Generous: tests must not depend on the speed of a loaded machine.
inline constexpr int kWaitMs = 30000;

inline std::vector<int16_t> sine(double hz, double amplitude, size_t count, uint32_t rate = kRate,
                                 uint64_t first = 0) {
  std::vector<int16_t> out(count);
  for (size_t i = 0; i < count; ++i) {
    const double t = static_cast<double>(first + i) / rate;
    out[i] = static_cast<int16_t>(
        std::lround(amplitude * 32767 * std::sin(2 * std::numbers::pi * hz * t)));
  }
  return out;
}

inline std::string pcmFrame(const int16_t* samples, size_t count, uint64_t seq,
                            uint32_t rate = kRate) {
  media::FrameHeader h;
  h.format = media::Format::pcm_s16le;
  h.seq = seq;
  h.channels = 1;
  h.sample_rate = rate;
  std::string payload(count * 2, '\0');
  for (size_t i = 0; i < count; ++i) {
    const auto v = static_cast<uint16_t>(samples[i]);
    payload[2 * i] = static_cast<char>(v & 0xff);
    payload[2 * i + 1] = static_cast<char>(v >> 8);
  }
  return media::makeFrame(h, payload);
}

inline std::vector<int16_t> samplesOf(const media::Frame& f) {
  std::vector<int16_t> out(f.payload.size() / 2);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = static_cast<int16_t>(static_cast<uint8_t>(f.payload[2 * i]) |
                                  static_cast<uint8_t>(f.payload[2 * i + 1]) << 8);
  }
  return out;
}

// Magnitude of the DFT of `x` at `hz` (Goertzel-like direct sum), normalised so that a sine of
// amplitude A gives about A/2 * 32767.
inline double dftMagnitude(const std::vector<int16_t>& x, double hz, uint32_t rate = kRate) {
  double re = 0, im = 0;
  const double w = 2 * std::numbers::pi * hz / rate;
  for (size_t i = 0; i < x.size(); ++i) {
    re += x[i] * std::cos(w * static_cast<double>(i));
    im -= x[i] * std::sin(w * static_cast<double>(i));
  }
  return std::hypot(re, im) / static_cast<double>(x.size());
}

// The frequency in [lo, hi] (step `step` Hz) with the largest DFT magnitude.
inline double dftPeakHz(const std::vector<int16_t>& x, double lo, double hi, double step,
                        uint32_t rate = kRate) {
  double best = lo, best_mag = -1;
  for (double f = lo; f <= hi; f += step) {
    const double m = dftMagnitude(x, f, rate);
    if (m > best_mag) best_mag = m, best = f;
  }
  return best;
}

inline std::optional<Json::Value> parseJson(std::string_view text) {
  Json::CharReaderBuilder b;
  std::unique_ptr<Json::CharReader> r(b.newCharReader());
  Json::Value v;
  std::string err;
  if (!r->parse(text.data(), text.data() + text.size(), &v, &err)) return std::nullopt;
  return v;
}

// A flow satellite that subscribes to channels by name and sorts incoming data by channel.
class Listener {
 public:
  Listener(TestClient flow, TestClient sync) : flow_(std::move(flow)), sync_(std::move(sync)) {}

  // Subscribes to `name`; false when the channel does not exist.
  bool subscribe(const std::string& name) {
    auto info = as<flow::msg::ChannelInfoReply>(sync_.call(flow::msg::ChanInfoByName{name}));
    if (!info) return false;
    ids_[info->info.id] = name;
    return flow_.send(flow::msg::Subscribe{next_tag_++, info->info.id});
  }
  std::optional<flow::Variant> channelProps(const std::string& name) {
    auto info = as<flow::msg::ChannelInfoReply>(sync_.call(flow::msg::ChanInfoByName{name}));
    if (!info) return std::nullopt;
    return info->info.props;
  }

  // Receives data until `done` returns true for the data collected so far, or the time is up.
  bool collect(const std::function<bool()>& done, int timeout_ms = kWaitMs) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!done()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      auto f = flow_.recv(static_cast<int>(left.count()));
      if (!f) return done();
      auto data = as<flow::msg::EvData>(f);
      if (!data) continue;
      auto it = ids_.find(data->chan_id);
      if (it == ids_.end()) continue;
      received[it->second].emplace_back(data->payload.bytes);
      order.push_back(it->second);
    }
    return true;
  }
  size_t count(const std::string& name) { return received[name].size(); }

  // An integer from database `db` (the module's own database is named after it).
  std::optional<int64_t> dbInt(const std::string& db, const std::string& key) {
    if (!sync_.call(flow::msg::DbSelect{db})) return std::nullopt;
    auto v = as<flow::msg::ReplyValue>(sync_.call(flow::msg::VarGet{key}));
    if (!v) return std::nullopt;
    return v->value.asInt64();
  }
  // Polls until db[key] == want (modules write counters once a second).
  bool waitDbInt(const std::string& db, const std::string& key, int64_t want,
                 int timeout_ms = kWaitMs) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (std::chrono::steady_clock::now() < end) {
      if (dbInt(db, key) == want) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }

  TestClient& flow() { return flow_; }
  TestClient& sync() { return sync_; }
  std::map<std::string, std::vector<std::string>> received;
  std::vector<std::string> order;  // channel of each message, in arrival order

 private:
  TestClient flow_;
  TestClient sync_;
  std::map<uint16_t, std::string> ids_;
  uint32_t next_tag_ = 1;
};

}  // namespace skr::test::audio
