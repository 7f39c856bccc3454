// SPDX-License-Identifier: Apache-2.0
// The JSON published on <name>.transcript, one object per utterance (docs/asr.md).
#pragma once

#include "engine.h"

#include <cstdint>
#include <string>

namespace skr::asr {

struct TranscriptFields {
  std::string instance;
  std::string mode;
  std::uint64_t utterance = 0;
  double start_s = 0, end_s = 0;  // speech, on the audio clock
  double audio_start_s = 0;       // what the engine was given starts here (word times' origin)
  double decided_s = 0;           // where the VAD decided the end (end + hang-over)
  bool cut = false;
  bool rejected = false;
  bool dropped = false;
  std::string error;
  double engine_ms = 0;
  AsrResult result;
};

// Compact JSON; word times are on the audio clock.
[[nodiscard]] std::string transcriptJson(const TranscriptFields& t);

}  // namespace skr::asr
