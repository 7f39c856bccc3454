// SPDX-License-Identifier: Apache-2.0
// Audio benchmarks, without the hub (what the modules' worker threads do):
//   fft-audio  CPU time per second of 22050 Hz audio for windows of 512..4096 samples, hop
//              size/2, Hann: the FFT alone, and with the JSON the module publishes
//   speech     espeak-ng synthesis real-time factor (synthesis time / audio duration) for an
//              English and an Italian sentence, default rate
// CPU time is the thread's (CLOCK_THREAD_CPUTIME_ID), so other processes loading the machine
// change the wall figures more than the CPU ones.
//
//   audio_bench [--quick]
#include "spectrum_analyser.h"
#include "synthesizer.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <numbers>
#include <random>
#include <string>
#include <variant>
#include <vector>

namespace {

double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}
double wallSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

std::vector<skr::audio::PcmChunk> testSignal(double seconds) {
  constexpr std::uint32_t kRate = 22050;
  const auto total = static_cast<std::size_t>(seconds * kRate);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 600);
  std::vector<skr::audio::PcmChunk> chunks;
  for (std::size_t at = 0; at < total; at += 1024) {
    skr::audio::PcmChunk c;
    c.seq = at;
    c.sample_rate = kRate;
    c.channels = 1;
    for (std::size_t i = at; i < std::min(total, at + 1024); ++i) {
      const double t = static_cast<double>(i) / kRate;
      c.samples.push_back(
          static_cast<std::int16_t>(8000 * std::sin(2 * std::numbers::pi * 440 * t) + noise(rng)));
    }
    chunks.push_back(std::move(c));
  }
  return chunks;
}

int benchFft(bool quick) {
  const double seconds = quick ? 5 : 120;
  const auto chunks = testSignal(seconds);
  std::printf("fft-audio: %.0f s of 22050 Hz mono audio, hop = size/2, Hann window\n", seconds);
  std::printf("%6s %10s %16s %16s %12s %12s\n", "size", "windows/s", "FFT ms CPU/s",
              "+JSON ms CPU/s", "% of a core", "JSON KB/s");
  for (std::size_t size : {512u, 1024u, 2048u, 4096u}) {
    double cpu[2] = {0, 0};
    std::size_t windows = 0, bytes = 0;
    for (int with_json = 0; with_json < 2; ++with_json) {
      skr::audio::AnalyserOptions o;
      o.size = size;
      o.hop = size / 2;
      skr::audio::SpectrumAnalyser analyser(o);
      windows = 0;
      bytes = 0;
      const double t0 = cpuSeconds();
      for (const auto& c : chunks) {
        analyser.feed(c, [&](const skr::audio::Analysis& a) {
          ++windows;
          if (with_json != 0) {
            bytes += skr::audio::spectrumJson(a, size).size();
            if (a.bands) bytes += skr::audio::bandsJson(a).size();
          }
        });
      }
      cpu[with_json] = cpuSeconds() - t0;
    }
    if (windows == 0) return 1;
    std::printf("%6zu %10.1f %16.3f %16.3f %11.2f%% %12.1f\n", size, windows / seconds,
                1000 * cpu[0] / seconds, 1000 * cpu[1] / seconds, 100 * cpu[1] / seconds,
                bytes / 1024.0 / seconds);
  }
  return 0;
}

int benchSpeech(bool quick) {
  struct Case {
    const char* voice;
    const char* text;
  };
  const Case cases[] = {
      {"en",
       "Hello, I am the robot of the laboratory. Today I will show you how I can see, "
       "listen and speak, and how my face follows what I say."},
      {"it",
       "Ciao, sono il robot del laboratorio. Oggi vi mostro come riesco a vedere, ascoltare "
       "e parlare, e come il mio viso segue quello che dico."},
  };
  const int reps = quick ? 1 : 20;
  skr::speech::Synthesizer synth;
  if (!synth.ok()) {
    std::fprintf(stderr, "espeak-ng: %s\n", synth.error().c_str());
    return 1;
  }
  std::printf("\nspeech: espeak-ng at %u Hz, %d repetitions, 175 wpm\n", synth.sampleRate(), reps);
  std::printf("%6s %10s %10s %14s %14s %12s %10s\n", "voice", "audio s", "phonemes",
              "synth ms wall", "synth ms CPU", "RTF (CPU)", "x realtime");
  for (const Case& c : cases) {
    double audio = 0, wall = 0, cpu = 0;
    std::size_t phonemes = 0;
    for (int r = 0; r < reps; ++r) {
      const double w0 = wallSeconds(), c0 = cpuSeconds();
      auto result = synth.say(c.text, {c.voice, 175, 50});
      wall += wallSeconds() - w0;
      cpu += cpuSeconds() - c0;
      const auto* u = std::get_if<skr::speech::Utterance>(&result);
      if (u == nullptr) {
        std::fprintf(stderr, "%s: %s\n", c.voice, std::get<std::string>(result).c_str());
        return 1;
      }
      audio += u->durationMs() / 1000.0;
      phonemes = u->phonemes.size();
    }
    std::printf("%6s %10.2f %10zu %14.2f %14.2f %12.4f %10.0f\n", c.voice, audio / reps, phonemes,
                1000 * wall / reps, 1000 * cpu / reps, cpu / audio, audio / wall);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  if (argc > 1 && !quick) {
    std::fprintf(stderr, "usage: audio_bench [--quick]\n");
    return 2;
  }
  if (benchFft(quick) != 0) return 1;
  return benchSpeech(quick);
}
