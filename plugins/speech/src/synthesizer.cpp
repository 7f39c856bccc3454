// SPDX-License-Identifier: Apache-2.0
#include "synthesizer.h"

#include <espeak-ng/speak_lib.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstring>
#include <string_view>

namespace skr::speech {
namespace {

std::atomic<bool> g_in_use{false};

struct Collector {
  Utterance* out;
  const std::string* text;
  std::vector<std::size_t> char_offsets;  // byte offset of each UTF-8 character, then the end
};

// espeak-ng counts text positions in characters from 1; map them to byte offsets.
std::vector<std::size_t> charOffsets(const std::string& text) {
  std::vector<std::size_t> offsets;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if ((static_cast<unsigned char>(text[i]) & 0xC0) != 0x80) offsets.push_back(i);
  }
  offsets.push_back(text.size());
  return offsets;
}

std::string wordAt(const Collector& c, int position, int length) {
  const auto n = static_cast<int>(c.char_offsets.size()) - 1;
  const int first = position - 1;
  if (first < 0 || first >= n || length <= 0) return {};
  const int last = std::min(n, first + length);
  return c.text->substr(c.char_offsets[first], c.char_offsets[last] - c.char_offsets[first]);
}

int onSynth(short* wav, int count, espeak_EVENT* events) {
  auto* c = static_cast<Collector*>(events->user_data);
  if (c == nullptr) return 0;
  if (wav != nullptr && count > 0) c->out->samples.insert(c->out->samples.end(), wav, wav + count);
  for (espeak_EVENT* e = events; e->type != espeakEVENT_LIST_TERMINATED; ++e) {
    if (e->type == espeakEVENT_PHONEME) {
      const std::string ph(e->id.string, strnlen(e->id.string, sizeof e->id.string));
      if (!ph.empty()) c->out->phonemes.push_back({ph, e->audio_position});
    } else if (e->type == espeakEVENT_WORD) {
      c->out->words.push_back({e->audio_position, wordAt(*c, e->text_position, e->length)});
    }
  }
  return 0;  // go on
}

// A face needs a strictly increasing timeline inside the audio: a phoneme that starts where the
// next one starts lasts 0 ms and is dropped; events after the end of the audio are dropped.
void tidy(Utterance& u) {
  const int end_ms = u.durationMs();
  std::vector<Phoneme> kept;
  for (auto& p : u.phonemes) {
    if (p.start_ms < 0 || p.start_ms >= end_ms) continue;
    if (!kept.empty() && p.start_ms <= kept.back().start_ms) kept.pop_back();
    if (!kept.empty() && p.start_ms <= kept.back().start_ms) continue;
    kept.push_back(std::move(p));
  }
  u.phonemes = std::move(kept);
  std::erase_if(u.words, [&](const Word& w) {
    return w.text.empty() || w.start_ms < 0 || w.start_ms >= end_ms;
  });
}

// espeak-ng's state is damaged by espeak_SetVoiceByName on a name it does not have (the next
// synthesis hangs, espeak-ng 1.51): look the name up in the voice list first. A voice matches by
// name, by file identifier, or by language ("en", "en-us", "it").
bool knownVoice(const std::string& name) {
  if (name.empty() || name.size() > 40) return false;
  auto same = [](std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
             return std::tolower(static_cast<unsigned char>(x)) ==
                    std::tolower(static_cast<unsigned char>(y));
           });
  };
  for (const espeak_VOICE** v = espeak_ListVoices(nullptr); v != nullptr && *v != nullptr; ++v) {
    const espeak_VOICE& voice = **v;
    if (voice.name != nullptr && same(voice.name, name)) return true;
    if (voice.identifier != nullptr) {
      const std::string_view id(voice.identifier);
      const auto slash = id.rfind('/');
      if (same(id, name) || same(id.substr(slash + 1), name)) return true;
    }
    // languages: a priority byte, then a NUL-terminated name, repeated; an empty name ends it.
    for (const char* l = voice.languages; l != nullptr && l[0] != 0 && l[1] != 0;
         l += std::strlen(l + 1) + 2) {
      if (same(l + 1, name)) return true;
    }
  }
  return false;
}

}  // namespace

Synthesizer::Synthesizer() {
  if (g_in_use.exchange(true)) {
    error_ = "espeak-ng is already in use in this process (one synthesizer only)";
    return;
  }
  owner_ = true;
  // Once per process, never terminated: espeak-ng 1.51 hangs in espeak_Terminate after a second
  // espeak_Initialize, so the library stays initialised until the process exits. DONT_EXIT: a
  // missing data directory must not exit() the hub.
  static const int rate =
      espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, 0, nullptr,
                        espeakINITIALIZE_PHONEME_EVENTS | espeakINITIALIZE_DONT_EXIT);
  if (rate <= 0) {
    error_ = "espeak_Initialize failed (is espeak-ng-data installed?)";
    return;
  }
  sample_rate_ = static_cast<std::uint32_t>(rate);
  espeak_SetSynthCallback(&onSynth);
}

Synthesizer::~Synthesizer() {
  if (owner_) g_in_use = false;
}

std::variant<Utterance, std::string> Synthesizer::say(const std::string& text, const Voice& voice) {
  if (!ok()) return error_;
  if (voice.name != current_voice_) {
    if (!knownVoice(voice.name) || espeak_SetVoiceByName(voice.name.c_str()) != EE_OK) {
      return "unknown voice '" + voice.name + "'";
    }
    current_voice_ = voice.name;
  }
  espeak_SetParameter(espeakRATE, voice.rate_wpm, 0);
  espeak_SetParameter(espeakPITCH, voice.pitch, 0);
  Utterance u;
  u.sample_rate = sample_rate_;
  Collector c{&u, &text, charOffsets(text)};
  const espeak_ERROR st = espeak_Synth(text.c_str(), text.size() + 1, 0, POS_CHARACTER, 0,
                                       espeakCHARS_UTF8, nullptr, &c);
  if (st != EE_OK) return "espeak_Synth failed (" + std::to_string(static_cast<int>(st)) + ")";
  espeak_Synchronize();
  tidy(u);
  return u;
}

}  // namespace skr::speech
