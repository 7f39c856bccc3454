// SPDX-License-Identifier: Apache-2.0
#include "transcript.h"

#include <json/json.h>

#include <cmath>

namespace skr::asr {

namespace {
double ms(double seconds) {
  return std::round(seconds * 1000) / 1000;
}  // 1 ms resolution
}  // namespace

std::string transcriptJson(const TranscriptFields& t) {
  Json::Value v(Json::objectValue);
  v["text"] = t.result.text;
  v["confidence"] = std::round(t.result.confidence * 1000) / 1000;
  v["start"] = ms(t.start_s);
  v["end"] = ms(t.end_s);
  Json::Value words(Json::arrayValue);
  for (const auto& w : t.result.words) {
    Json::Value j(Json::objectValue);
    j["word"] = w.word;
    j["start"] = ms(t.audio_start_s + w.start_s);
    j["end"] = ms(t.audio_start_s + w.end_s);
    words.append(j);
  }
  v["words"] = words;
  v["instance"] = t.instance;
  v["mode"] = t.mode;
  v["cut"] = t.cut;
  v["rejected"] = t.rejected;
  v["utterance"] = Json::UInt64(t.utterance);
  v["end_decided"] = ms(t.decided_s);
  v["engine_ms"] = std::round(t.engine_ms * 10) / 10;
  if (t.result.scored) {
    v["reject_score"] = std::round(t.result.reject_score * 100) / 100;
    v["unplaced"] = std::round(t.result.unplaced * 100) / 100;
  }
  if (t.dropped) v["dropped"] = true;
  if (!t.error.empty()) v["error"] = t.error;
  Json::StreamWriterBuilder b;
  b["indentation"] = "";
  b["emitUTF8"] = true;
  return Json::writeString(b, v);
}

}  // namespace skr::asr
