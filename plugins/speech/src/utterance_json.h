// SPDX-License-Identifier: Apache-2.0
// The JSON messages of the speech module (docs/audio.md).
#pragma once

#include "synthesizer.h"

#include <cstdint>
#include <string>

namespace skr::speech {

// On <name>.phonemes, before the utterance's first audio frame:
// {"utterance","start_seq","sample_rate","duration_ms","text","voice",
//  "phonemes":[{"ph","start_ms"}...],"words":[{"word","start_ms"}...]}
std::string phonemesJson(std::uint64_t id, std::uint64_t start_seq, const Utterance& u,
                         const std::string& text, const std::string& voice);
// The service response: {"utterance","duration_ms","samples","phonemes"}
std::string responseJson(std::uint64_t id, const Utterance& u);
// The answer to a request that failed: {"error": message}
std::string errorJson(const std::string& message);

}  // namespace skr::speech
