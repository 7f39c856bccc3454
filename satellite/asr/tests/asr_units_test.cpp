// SPDX-License-Identifier: Apache-2.0
// The parts of skrobot-asr on generated signals: resampler, VAD, segmenter.
#include "resampler.h"
#include "segmenter.h"
#include "vad.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace skr::asr {
namespace {

std::vector<std::int16_t> sine(double hz, double rate, std::size_t n, double amplitude) {
  std::vector<std::int16_t> s(n);
  for (std::size_t i = 0; i < n; ++i) {
    s[i] = static_cast<std::int16_t>(amplitude * 32767 *
                                     std::sin(2 * std::numbers::pi * hz * i / rate));
  }
  return s;
}

// Amplitude of `hz` in `x` (a single-bin DFT over a Hann window), 1.0 for a full-scale sine.
double amplitudeAt(const std::vector<std::int16_t>& x, double hz, double rate) {
  double re = 0, im = 0, wsum = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * i / (x.size() - 1));
    re += w * x[i] / 32768.0 * std::cos(2 * std::numbers::pi * hz * i / rate);
    im -= w * x[i] / 32768.0 * std::sin(2 * std::numbers::pi * hz * i / rate);
    wsum += w;
  }
  return 2 * std::hypot(re, im) / wsum;
}

// Resampled in chunks of odd sizes, as frames arrive.
std::vector<std::int16_t> resample(const std::vector<std::int16_t>& in, std::uint32_t from,
                                   std::uint32_t to) {
  Resampler r(from, to);
  std::vector<std::int16_t> out;
  for (std::size_t i = 0; i < in.size(); i += 441) {
    const std::size_t n = std::min<std::size_t>(441, in.size() - i);
    r.process(std::span(in).subspan(i, n), out);
  }
  return out;
}

TEST(Resampler, KeepsASinesFrequencyAndLevel) {
  for (const double hz : {300.0, 1000.0, 3000.0, 6000.0}) {
    const auto in = sine(hz, 22050, 22050, 0.5);
    const auto out = resample(in, 22050, 16000);
    // Output count: one per 22050/16000 input samples, less the kernel's lag.
    EXPECT_NEAR(static_cast<double>(out.size()), 16000, 40) << hz;
    const std::vector<std::int16_t> mid(out.begin() + 1000, out.end() - 1000);
    EXPECT_NEAR(amplitudeAt(mid, hz, 16000), 0.5, 0.01) << hz << " Hz";
    // Nothing else: a neighbouring frequency is far down.
    EXPECT_LT(amplitudeAt(mid, hz + 211, 16000), 0.005) << hz << " Hz";
  }
}

TEST(Resampler, NoAliasingAboveNyquist) {
  // 10 kHz at 22050 Hz has no place at 16 kHz (Nyquist 8 kHz): sample dropping would fold it to
  // 6 kHz at full level. The low-pass must take it down by 60 dB at least.
  for (const double hz : {9000.0, 10000.0, 10500.0}) {
    const auto out = resample(sine(hz, 22050, 22050, 0.9), 22050, 16000);
    const std::vector<std::int16_t> mid(out.begin() + 1000, out.end() - 1000);
    const double alias = 16000 - hz;
    EXPECT_LT(amplitudeAt(mid, alias, 16000), 0.9e-3) << hz << " Hz folds to " << alias;
  }
}

TEST(Resampler, UpsamplesAndKeepsTime) {
  const auto in = sine(440, 8000, 8000, 0.5);
  const auto out = resample(in, 8000, 16000);
  EXPECT_NEAR(static_cast<double>(out.size()), 16000, 40);
  const std::vector<std::int16_t> mid(out.begin() + 1000, out.end() - 1000);
  EXPECT_NEAR(amplitudeAt(mid, 440, 16000), 0.5, 0.01);
  // No phase shift: output n is the input at n / 2.
  EXPECT_NEAR(out[4001], 0.5 * 32767 * std::sin(2 * std::numbers::pi * 440 * 4001 / 16000.0), 300);
}

// A test signal: noise at `noise_db` with tone bursts at `tone_db` in [start, end) seconds.
std::vector<std::int16_t> bursts(double seconds, double noise_db, double tone_db,
                                 const std::vector<std::pair<double, double>>& on) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0, 1);
  const double noise = std::pow(10, noise_db / 20) * 32767;
  const double tone = std::pow(10, tone_db / 20) * 32767 * std::sqrt(2.0);
  std::vector<std::int16_t> s(static_cast<std::size_t>(seconds * 16000));
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double t = i / 16000.0;
    double v = noise * gauss(rng);
    for (const auto& [a, b] : on) {
      if (t >= a && t < b) v += tone * std::sin(2 * std::numbers::pi * 440 * t);
    }
    s[i] = static_cast<std::int16_t>(std::clamp(v, -32768.0, 32767.0));
  }
  return s;
}

struct Collected {
  std::vector<UtteranceBounds> ends;
  std::size_t samples = 0;
  int starts = 0;
};

Collected segment(const std::vector<std::int16_t>& s, SegmenterOptions options = {}) {
  Collected c;
  Segmenter seg(options,
                SegmenterSink{
                    .start = [&](const UtteranceBounds&) { ++c.starts; },
                    .audio = [&](std::span<const std::int16_t> a) { c.samples += a.size(); },
                    .end = [&](const UtteranceBounds& b) { c.ends.push_back(b); },
                });
  for (std::size_t i = 0; i < s.size(); i += 320) {
    seg.push(std::span(s).subspan(i, std::min<std::size_t>(320, s.size() - i)));
  }
  seg.flush();
  return c;
}

TEST(Vad, SilenceAndSteadyNoiseAreNotSpeech) {
  EXPECT_TRUE(segment(std::vector<std::int16_t>(16000 * 10, 0)).ends.empty());
  EXPECT_TRUE(segment(bursts(10, -40, -120, {})).ends.empty());  // hiss at -40 dBFS
  EXPECT_TRUE(segment(bursts(10, -20, -120, {})).ends.empty());  // loud noise: it is the floor
}

TEST(Vad, ToneBurstsGiveSegmentsAtTheirPlaces) {
  const std::vector<std::pair<double, double>> on = {{1.0, 1.8}, {3.0, 3.4}, {5.2, 7.0}};
  const auto c = segment(bursts(9, -50, -20, on));
  ASSERT_EQ(c.ends.size(), on.size());
  EXPECT_EQ(c.starts, 3);
  for (std::size_t i = 0; i < on.size(); ++i) {
    EXPECT_NEAR(c.ends[i].speech_start / 16000.0, on[i].first, 0.03) << i;
    EXPECT_NEAR(c.ends[i].speech_end / 16000.0, on[i].second, 0.03) << i;
    // The end is decided one hang-over later.
    EXPECT_NEAR((c.ends[i].decided_at - c.ends[i].speech_end) / 16000.0, 0.3, 0.02) << i;
    EXPECT_FALSE(c.ends[i].cut);
    EXPECT_NEAR((c.ends[i].speech_start - c.ends[i].audio_start) / 16000.0, 0.2, 0.011) << i;
  }
}

TEST(Vad, NoiseFloorFollowsALouderBackground) {
  // The background steps from -60 to -35 dBFS: one utterance at the step (at most), then the
  // floor has caught up and a burst over the new background is found again.
  auto quiet = bursts(4, -60, -120, {});
  auto loud = bursts(20, -35, -10, {{17.0, 18.0}});
  quiet.insert(quiet.end(), loud.begin(), loud.end());
  const auto c = segment(quiet);
  ASSERT_GE(c.ends.size(), 1u);
  ASSERT_LE(c.ends.size(), 2u);
  EXPECT_NEAR(c.ends.back().speech_start / 16000.0, 21.0, 0.05);
  EXPECT_NEAR(c.ends.back().speech_end / 16000.0, 22.0, 0.05);
}

TEST(Segmenter, CutsALongUtteranceAtMaxLength) {
  SegmenterOptions options;
  options.max_utterance_s = 5;
  // 21 s of "syllables" (250 ms of tone, 100 ms pauses: speech has pauses, a steady tone would
  // become the noise floor).
  std::vector<std::pair<double, double>> syllables;
  for (double t = 1.0; t < 21.9; t += 0.35) syllables.emplace_back(t, std::min(t + 0.25, 22.0));
  syllables.back().second = 22.0;
  const auto c = segment(bursts(23, -50, -20, syllables), options);
  // 21 s of speech: 5 + 5 + 5 + 5 cut, then the rest (about 1 s) ends normally.
  ASSERT_EQ(c.ends.size(), 5u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(c.ends[i].cut) << i;
    EXPECT_LE(c.ends[i].speech_end - c.ends[i].audio_start, 5u * 16000 + 160) << i;
  }
  EXPECT_FALSE(c.ends[4].cut);
  EXPECT_NEAR(c.ends[4].speech_end / 16000.0, 22.0, 0.03);
  // Everything handed on is bounded by the utterances (plus pre-roll), nothing accumulates.
  EXPECT_LT(c.samples, static_cast<std::size_t>(23 * 16000));
}

}  // namespace
}  // namespace skr::asr
