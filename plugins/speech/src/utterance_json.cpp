// SPDX-License-Identifier: Apache-2.0
#include "utterance_json.h"

#include <skrobot/support/json.hpp>

namespace skr::speech {

std::string phonemesJson(std::uint64_t id, std::uint64_t start_seq, const Utterance& u,
                         const std::string& text, const std::string& voice) {
  Json::Value v(Json::objectValue);
  v["utterance"] = Json::UInt64(id);
  v["start_seq"] = Json::UInt64(start_seq);
  v["sample_rate"] = u.sample_rate;
  v["duration_ms"] = u.durationMs();
  v["text"] = text;
  v["voice"] = voice;
  Json::Value phonemes(Json::arrayValue);
  for (const Phoneme& p : u.phonemes) {
    Json::Value e(Json::objectValue);
    e["ph"] = p.ph;
    e["start_ms"] = p.start_ms;
    phonemes.append(std::move(e));
  }
  v["phonemes"] = std::move(phonemes);
  Json::Value words(Json::arrayValue);
  for (const Word& w : u.words) {
    Json::Value e(Json::objectValue);
    e["word"] = w.text;
    e["start_ms"] = w.start_ms;
    words.append(std::move(e));
  }
  v["words"] = std::move(words);
  return support::writeJson(v);
}

std::string responseJson(std::uint64_t id, const Utterance& u) {
  Json::Value v(Json::objectValue);
  v["utterance"] = Json::UInt64(id);
  v["duration_ms"] = u.durationMs();
  v["samples"] = Json::UInt64(u.samples.size());
  v["phonemes"] = Json::UInt64(u.phonemes.size());
  return support::writeJson(v);
}

std::string errorJson(const std::string& message) {
  Json::Value v(Json::objectValue);
  v["error"] = message;
  return support::writeJson(v);
}

}  // namespace skr::speech
