// SPDX-License-Identifier: Apache-2.0
#include "resampler.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace skr::asr {

namespace {

constexpr int kTableSteps = 512;  // kernel points per input sample (linear interpolation between)
constexpr double kKaiserBeta = 8.6;

double besselI0(double x) {
  double sum = 1, term = 1;
  for (int k = 1; k < 50; ++k) {
    term *= (x / (2 * k)) * (x / (2 * k));
    sum += term;
    if (term < sum * 1e-12) break;
  }
  return sum;
}

}  // namespace

Resampler::Resampler(std::uint32_t in_rate_hz, std::uint32_t out_rate_hz, int zero_crossings)
    : in_rate_(in_rate_hz), out_rate_(out_rate_hz) {
  // Pass band up to ~91% of the lower Nyquist frequency; the transition band ends at it.
  const double ratio = std::min(1.0, static_cast<double>(out_rate_) / in_rate_);
  cutoff_ = 0.5 * ratio * 0.955;
  half_width_ = static_cast<int>(std::ceil(zero_crossings / (2.0 * cutoff_)));
  table_.resize(static_cast<std::size_t>(half_width_) * kTableSteps + 2);
  const double i0beta = besselI0(kKaiserBeta);
  for (std::size_t i = 0; i < table_.size(); ++i) {
    const double t = static_cast<double>(i) / kTableSteps;
    const double x = t / half_width_;
    if (x >= 1) {
      table_[i] = 0;
      continue;
    }
    const double arg = 2 * cutoff_ * t;
    const double sinc = arg == 0 ? 1 : std::sin(std::numbers::pi * arg) / (std::numbers::pi * arg);
    const double window = besselI0(kKaiserBeta * std::sqrt(1 - x * x)) / i0beta;
    table_[i] = static_cast<float>(2 * cutoff_ * sinc * window);
  }
}

float Resampler::kernel(double t) const noexcept {
  const double pos = std::fabs(t) * kTableSteps;
  const auto i = static_cast<std::size_t>(pos);
  if (i + 1 >= table_.size()) return 0;
  const double f = pos - static_cast<double>(i);
  return static_cast<float>(table_[i] + (table_[i + 1] - table_[i]) * f);
}

double Resampler::nextOutputTime() const noexcept {
  return static_cast<double>(next_out_) * in_rate_ / out_rate_;
}

void Resampler::reset() {
  history_.clear();
  history_start_ = 0;
  next_out_ = 0;
}

void Resampler::process(std::span<const std::int16_t> in, std::vector<std::int16_t>& out) {
  for (const auto s : in) history_.push_back(static_cast<float>(s));
  const std::uint64_t have = history_start_ + history_.size();  // input samples so far
  for (;;) {
    // Output n sits at input time n * in / out = centre + frac / out.
    const std::uint64_t num = next_out_ * in_rate_;
    const std::uint64_t centre = num / out_rate_;
    const double frac = static_cast<double>(num % out_rate_) / out_rate_;
    if (centre + half_width_ + 1 > have) break;  // needs more input
    const std::int64_t first = static_cast<std::int64_t>(centre) - half_width_ + 1;
    double acc = 0;
    for (std::int64_t k = std::max<std::int64_t>(first, 0);
         k <= static_cast<std::int64_t>(centre) + half_width_; ++k) {
      if (static_cast<std::uint64_t>(k) < history_start_) continue;  // before the stream
      const double t = static_cast<double>(k) - static_cast<double>(centre) - frac;
      acc += history_[static_cast<std::size_t>(k) - history_start_] * kernel(t);
    }
    out.push_back(static_cast<std::int16_t>(std::clamp(std::lround(acc), -32768L, 32767L)));
    ++next_out_;
  }
  // Keep what the next output still needs.
  const std::uint64_t next_centre = next_out_ * in_rate_ / out_rate_;
  const std::uint64_t keep_from =
      next_centre > static_cast<std::uint64_t>(half_width_) ? next_centre - half_width_ : 0;
  while (history_start_ < keep_from && !history_.empty()) {
    history_.pop_front();
    ++history_start_;
  }
}

}  // namespace skr::asr
