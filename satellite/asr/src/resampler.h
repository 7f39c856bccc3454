// SPDX-License-Identifier: Apache-2.0
// A streaming sample-rate converter: Kaiser-windowed sinc interpolation at any ratio, with the
// low-pass cut below the lower of the two Nyquist frequencies (so going down from 22050 Hz to
// 16 kHz removes what 16 kHz cannot carry instead of folding it back).
//
// Output sample n stands at input time n * in_rate / out_rate exactly (the kernel is symmetric:
// no phase shift); it is produced once the kernel's half width of later input has arrived, so the
// output lags the input by halfWidth() input samples. Single-threaded; no allocation per call
// beyond the output vector and the input history (bounded by the kernel's width).
#pragma once

#include <cstdint>
#include <deque>
#include <span>
#include <vector>

namespace skr::asr {

class Resampler {
 public:
  // Rates in Hz, each 1000..384000. `zero_crossings`: the kernel's half width in zero crossings
  // of the sinc (quality against CPU; 16 gives > 80 dB stop band with the Kaiser beta used).
  Resampler(std::uint32_t in_rate_hz, std::uint32_t out_rate_hz, int zero_crossings = 16);

  // Appends the output that `in` completes to `out`.
  void process(std::span<const std::int16_t> in, std::vector<std::int16_t>& out);
  // Forgets all input (after a gap): the next sample is the start of a new stream.
  void reset();

  [[nodiscard]] std::uint32_t inRate() const noexcept { return in_rate_; }
  [[nodiscard]] std::uint32_t outRate() const noexcept { return out_rate_; }
  [[nodiscard]] int halfWidth() const noexcept { return half_width_; }  // input samples
  // The input time of the next output sample, in input samples since the stream began.
  [[nodiscard]] double nextOutputTime() const noexcept;

 private:
  [[nodiscard]] float kernel(double t) const noexcept;  // t in input samples, |t| <= half width

  std::uint32_t in_rate_, out_rate_;
  double cutoff_;              // cycles per input sample
  int half_width_;             // input samples either side of the output time
  std::vector<float> table_;   // the kernel at kTableSteps points per input sample, t >= 0
  std::deque<float> history_;  // input samples from index history_start_
  std::uint64_t history_start_ = 0;
  std::uint64_t next_out_ = 0;  // index of the next output sample
};

}  // namespace skr::asr
