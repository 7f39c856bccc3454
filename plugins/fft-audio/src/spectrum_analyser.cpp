// SPDX-License-Identifier: Apache-2.0
#include "spectrum_analyser.h"

#include <skrobot/support/json.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>

namespace skr::audio {
namespace {

constexpr double kFloorDb = -120;
constexpr double kLowestBandHz = 60;

// A number rounded to `decimals` places, for compact published values.
double rounded(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

double toDb(double amplitude) {
  return amplitude > 0 ? std::max(kFloorDb, 20 * std::log10(amplitude)) : kFloorDb;
}

std::vector<double> makeWindow(Window w, std::size_t n) {
  std::vector<double> out(n, 1.0);
  const double k = 2 * std::numbers::pi / static_cast<double>(n);  // periodic windows
  for (std::size_t i = 0; i < n; ++i) {
    const double x = k * static_cast<double>(i);
    switch (w) {
      case Window::hann:
        out[i] = 0.5 - 0.5 * std::cos(x);
        break;
      case Window::hamming:
        out[i] = 0.54 - 0.46 * std::cos(x);
        break;
      case Window::blackman:
        out[i] = 0.42 - 0.5 * std::cos(x) + 0.08 * std::cos(2 * x);
        break;
      case Window::rectangular:
        break;
    }
  }
  return out;
}

}  // namespace

std::optional<Window> windowFromName(const std::string& name) {
  if (name == "hann") return Window::hann;
  if (name == "hamming") return Window::hamming;
  if (name == "blackman") return Window::blackman;
  if (name == "rectangular") return Window::rectangular;
  return std::nullopt;
}

SpectrumAnalyser::SpectrumAnalyser(const AnalyserOptions& options)
    : options_(options),
      plan_(options.size),
      window_(makeWindow(options.window, options.size)),
      bins_(options.size / 2 + 1) {
  for (double w : window_) window_sum_ += w;
  pending_.reserve(options.size * 2);
}

void SpectrumAnalyser::reset() noexcept {
  pending_.clear();
  streaming_ = false;
  last_bands_seq_.reset();
}

void SpectrumAnalyser::feed(const PcmChunk& chunk,
                            const std::function<void(const Analysis&)>& emit) {
  const std::size_t frames = chunk.frames();
  if (frames == 0) return;
  const bool continues =
      streaming_ && chunk.sample_rate == rate_ && chunk.seq == pending_seq_ + pending_.size();
  if (chunk.discontinuity || !continues) {
    if (chunk.sample_rate != rate_) last_bands_seq_.reset();
    pending_.clear();
    pending_seq_ = chunk.seq;
    pending_capture_ns_ = chunk.capture_ns;
    rate_ = chunk.sample_rate;
    streaming_ = true;
  }
  const std::size_t ch = chunk.channels;
  for (std::size_t i = 0; i < frames; ++i) {
    double sum = 0;
    for (std::size_t c = 0; c < ch; ++c) sum += chunk.samples[i * ch + c];
    pending_.push_back(sum / (32768.0 * static_cast<double>(ch)));
  }
  while (pending_.size() >= options_.size) {
    analyse(rate_, emit);
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<long>(options_.hop));
    // The capture time of later windows: the chunk's, advanced by the samples shifted out.
    if (pending_capture_ns_ != 0) {
      pending_capture_ns_ += static_cast<std::int64_t>(options_.hop * 1'000'000'000ULL / rate_);
    }
    pending_seq_ += options_.hop;
  }
}

void SpectrumAnalyser::analyse(std::uint32_t rate,
                               const std::function<void(const Analysis&)>& emit) {
  const std::size_t n = options_.size;
  double* in = plan_.input();
  double energy = 0;
  for (std::size_t i = 0; i < n; ++i) {
    energy += pending_[i] * pending_[i];
    in[i] = pending_[i] * window_[i];
  }
  plan_.execute();
  const std::complex<double>* out = plan_.output();
  const double scale = 2.0 / window_sum_;
  std::size_t peak = 1;
  for (std::size_t k = 0; k < bins_.size(); ++k) {
    bins_[k] = std::abs(out[k]) * scale;
    if (k >= 1 && bins_[k] > bins_[peak]) peak = k;
  }
  // Parabolic interpolation on log magnitudes around the peak bin.
  double offset = 0;
  if (peak > 0 && peak + 1 < bins_.size()) {
    const double a = toDb(bins_[peak - 1]), b = toDb(bins_[peak]), c = toDb(bins_[peak + 1]);
    const double d = a - 2 * b + c;
    if (d < 0) offset = std::clamp(0.5 * (a - c) / d, -0.5, 0.5);
  }

  Analysis r;
  r.seq = pending_seq_;
  r.capture_ns = pending_capture_ns_;
  r.sample_rate = rate;
  r.level_db = toDb(std::sqrt(energy / static_cast<double>(n)));
  r.peak_bin = peak;
  r.peak_hz = (static_cast<double>(peak) + offset) * rate / static_cast<double>(n);
  r.bins = &bins_;
  const auto every = static_cast<std::uint64_t>(std::max(1.0, rate / options_.bands_rate_hz));
  if (!last_bands_seq_ || r.seq >= *last_bands_seq_ + every) {
    r.bands.emplace();
    computeBands(rate, *r.bands);
    last_bands_seq_ = r.seq;
  }
  emit(r);
}

void SpectrumAnalyser::computeBands(std::uint32_t rate, std::array<double, kBands>& out) const {
  const double nyquist = rate / 2.0;
  const double hz_per_bin = static_cast<double>(rate) / static_cast<double>(options_.size);
  const double ratio = nyquist / kLowestBandHz;
  for (std::size_t b = 0; b < kBands; ++b) {
    const double lo = kLowestBandHz * std::pow(ratio, static_cast<double>(b) / kBands);
    const double hi = kLowestBandHz * std::pow(ratio, static_cast<double>(b + 1) / kBands);
    auto first = static_cast<std::size_t>(std::ceil(lo / hz_per_bin));
    auto last = static_cast<std::size_t>(std::floor(hi / hz_per_bin));
    first = std::min(first, bins_.size() - 1);
    last = std::clamp(last, first, bins_.size() - 1);  // narrow bands take their nearest bin
    double m = 0;
    for (std::size_t k = first; k <= last; ++k) m = std::max(m, bins_[k]);
    out[b] = std::clamp((toDb(m) - options_.min_db) / -options_.min_db, 0.0, 1.0);
  }
}

// Written by hand, numbers only (no strings to escape): building a Json::Value cost ~20 times the
// FFT's time on the 513 bins of a 1024 window.
std::string spectrumJson(const Analysis& a, std::size_t size) {
  std::string out;
  out.reserve(64 + a.bins->size() * 10);
  char num[32];
  auto put = [&](double v, int digits) {
    const auto r = std::to_chars(num, num + sizeof num, v, std::chars_format::general, digits);
    out.append(num, r.ptr);
  };
  out += R"({"seq":)" + std::to_string(a.seq) + R"(,"capture_ns":)" + std::to_string(a.capture_ns) +
         R"(,"sample_rate":)" + std::to_string(a.sample_rate) + R"(,"size":)" +
         std::to_string(size) + R"(,"level_db":)";
  put(rounded(a.level_db, 2), 8);
  out += R"(,"peak_hz":)";
  put(rounded(a.peak_hz, 2), 8);
  out += R"(,"bins":[)";
  for (std::size_t k = 0; k < a.bins->size(); ++k) {
    if (k > 0) out += ',';
    const double m = (*a.bins)[k];
    if (m < 1e-7) {
      out += '0';  // below -140 dBFS
    } else {
      put(m, 4);  // 4 significant digits: far finer than any display
    }
  }
  out += "]}";
  return out;
}

std::string bandsJson(const Analysis& a) {
  Json::Value v(Json::objectValue);
  v["seq"] = Json::UInt64(a.seq);
  v["level_db"] = rounded(a.level_db, 2);
  Json::Value bands(Json::arrayValue);
  if (a.bands) {
    for (double b : *a.bands) bands.append(rounded(b, 3));
  }
  v["bands"] = std::move(bands);
  return support::writeJson(v);
}

}  // namespace skr::audio
