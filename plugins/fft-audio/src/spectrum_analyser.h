// SPDX-License-Identifier: Apache-2.0
// Short-time spectrum of a PCM stream: windows of `size` samples every `hop` samples, magnitude
// bins, RMS level, peak frequency, and a coarse view of 16 log-spaced bands. No threads: the
// fft-audio module runs it on its worker, the benchmark directly.
#pragma once

#include <skrobot/audio/pcm_input.h>
#include "fft_plan.h"

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace skr::audio {

enum class Window { hann, hamming, blackman, rectangular };
// "hann", "hamming", "blackman", "rectangular"; nullopt for anything else.
std::optional<Window> windowFromName(const std::string& name);

struct AnalyserOptions {
  std::size_t size = 1024;  // samples per window (>= 32)
  std::size_t hop = 512;    // samples between windows (1..size)
  Window window = Window::hann;
  double bands_rate_hz = 30;  // at most this many band views per second of audio
  double min_db = -90;        // band value 0; 0 dBFS is 1
};

inline constexpr std::size_t kBands = 16;

struct Analysis {
  std::uint64_t seq = 0;  // first sample of the window
  std::int64_t capture_ns = 0;
  std::uint32_t sample_rate = 0;
  double level_db = 0;  // RMS of the window in dBFS (floor -120)
  double peak_hz = 0;
  std::size_t peak_bin = 0;
  const std::vector<double>* bins = nullptr;  // size/2+1 amplitudes (a full-scale sine gives ~1)
  std::optional<std::array<double, kBands>> bands;  // only when a band view is due
};

class SpectrumAnalyser {
 public:
  explicit SpectrumAnalyser(const AnalyserOptions& options);  // makes the FFTW plan

  // Feeds one chunk (any channel count: mixed to mono). A discontinuity, or a change of rate,
  // restarts the window at the chunk. Calls `emit` once per complete window.
  void feed(const PcmChunk& chunk, const std::function<void(const Analysis&)>& emit);
  // Forgets buffered samples (the next chunk starts a new window).
  void reset() noexcept;

  [[nodiscard]] const AnalyserOptions& options() const noexcept { return options_; }

 private:
  void analyse(std::uint32_t rate, const std::function<void(const Analysis&)>& emit);
  void computeBands(std::uint32_t rate, std::array<double, kBands>& out) const;

  AnalyserOptions options_;
  FftPlan plan_;
  std::vector<double> window_;
  double window_sum_ = 0;
  std::vector<double> pending_;  // samples not yet shifted out, pending_[0] is pending_seq_
  std::uint64_t pending_seq_ = 0;
  std::int64_t pending_capture_ns_ = 0;
  std::uint32_t rate_ = 0;
  bool streaming_ = false;  // pending_ continues the stream (false after reset)
  std::vector<double> bins_;
  std::optional<std::uint64_t> last_bands_seq_;
};

// {"seq","capture_ns","sample_rate","size","level_db","peak_hz","bins":[...]}
std::string spectrumJson(const Analysis& a, std::size_t size);
// {"seq","level_db","bands":[16 values 0..1]}
std::string bandsJson(const Analysis& a);

}  // namespace skr::audio
