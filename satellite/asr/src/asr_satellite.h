// SPDX-License-Identifier: Apache-2.0
// The speech-recognition satellite: subscribes to an audio channel, finds utterances, hands them
// to the recogniser's worker and publishes what it heard on <user>.<name>.transcript; answers
// commands on <user>.<name>.control (docs/asr.md).
//
// Threading: everything here runs on the satellite's loop thread (the audio path only parses,
// resamples and measures energy: a few percent of a core at most); the engine runs on the
// Recognizer's worker, whose results are posted back to the loop.
#pragma once

#include "engine.h"
#include "recognizer.h"
#include "resampler.h"
#include "segmenter.h"

#include <skrobot/satellite.h>

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skr::asr {

struct AsrOptions {
  std::string input = "websocket-ui.mic";  // the audio channel (media frames, PCM s16le mono)
  std::string name = "asr";                // the instance: channels <name>.transcript, .control
  std::string grammar_jsgf;                // start in grammar mode with this grammar, or
  std::vector<std::string> keywords;       // with these phrases
  SegmenterOptions segmenter;              // VAD (hang-over), pre-roll, max utterance length
  double max_queued_s = 30;                // audio waiting for the worker before dropping
};

struct AsrCounters {
  std::uint64_t frames = 0;
  std::uint64_t ignored = 0;  // frames refused: not a PCM media frame, wrong format or channels
  std::uint64_t gaps = 0;
  std::uint64_t utterances = 0;  // transcripts published
  std::uint64_t rejected = 0;
  std::uint64_t cut = 0;
  std::uint64_t dropped = 0;
  std::uint64_t errors = 0;
};

class AsrSatellite {
 public:
  // Declares the channels and subscribes; call before sat.start(). The engine is moved to the
  // worker thread.
  AsrSatellite(Loop& loop, sat::Satellite& sat, AsrOptions options,
               std::unique_ptr<AsrEngine> engine);
  ~AsrSatellite();
  AsrSatellite(const AsrSatellite&) = delete;
  AsrSatellite& operator=(const AsrSatellite&) = delete;
  AsrSatellite(AsrSatellite&&) = delete;
  AsrSatellite& operator=(AsrSatellite&&) = delete;

  [[nodiscard]] const AsrCounters& counters() const noexcept { return counters_; }

 private:
  void onSubscribed(const sat::ChannelInfo& info);
  void onData(std::uint16_t id, std::string_view payload);
  void onRequest(const sat::Request& request);
  void onHeard(Heard heard);  // loop thread
  void announceStart(const UtteranceBounds& b);
  // "recognise": given audio, as one utterance, between two of the stream's.
  void recogniseGiven(const sat::Request& request, const flow::Variant::Map& value);
  void checkProperties(const flow::Variant& props);
  void rebase(std::uint64_t seq, std::uint32_t rate, std::int64_t capture_ns);
  [[nodiscard]] double clockAt(std::uint64_t sample16) const noexcept;
  void ignore(const std::string& reason);
  void respondLater(const sat::Request& request, std::function<Result<void>(AsrEngine&)> fn,
                    std::string mode_after);
  [[nodiscard]] flow::Variant status() const;

  Loop& loop_;
  sat::Satellite& sat_;
  AsrOptions options_;
  std::string transcript_, control_;  // short names
  std::string engine_name_;
  std::string mode_ = "dictation";  // as the engine has it after the commands so far
  std::string last_grammar_;        // for set_mode grammar
  std::unique_ptr<Recognizer> recognizer_;
  Segmenter segmenter_;
  std::optional<Resampler> resampler_;
  std::vector<std::int16_t> out16_;
  std::uint16_t input_id_ = 0;
  bool props_ok_ = true;
  std::string last_ignored_;
  bool paused_ = false;
  // Utterances handed over by "recognise", by number: where their audio starts on the clock.
  std::map<std::uint64_t, double> given_;
  bool have_stream_ = false;
  std::uint64_t expected_seq_ = 0;
  std::uint32_t rate_ = 0;
  std::uint64_t pushed16_ = 0;  // 16 kHz samples handed to the segmenter
  std::uint64_t base16_ = 0;    // the 16 kHz sample at clock time base_s_
  double base_s_ = 0;
  AsrCounters counters_;
  std::shared_ptr<std::atomic<bool>> alive_ = std::make_shared<std::atomic<bool>>(true);
};

}  // namespace skr::asr
