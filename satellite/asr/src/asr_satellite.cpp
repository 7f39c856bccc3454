// SPDX-License-Identifier: Apache-2.0
#include "asr_satellite.h"

#include "transcript.h"

#include <skrobot/runtime/log.h>
#include <skrobot/media_frame.hpp>

#include <cmath>

namespace skr::asr {

namespace {

constexpr std::string_view kLog = "asr";
constexpr std::uint32_t kMinRateHz = 8000;
constexpr std::uint32_t kMaxRateHz = 192000;

flow::Variant errorValue(const std::string& message) {
  return flow::Variant::Map{{"error", flow::Variant(message)}};
}

// A request's value as a map: a map as is, or JSON text holding one.
std::optional<flow::Variant> valueMap(const flow::Variant& value) {
  if (value.isMap()) return value;
  if (const auto* text = value.asString()) {
    auto parsed = flow::variantFromJsonText(*text);
    if (parsed && parsed->isMap()) return std::move(parsed).value();
  }
  return std::nullopt;
}

}  // namespace

AsrSatellite::AsrSatellite(Loop& loop, sat::Satellite& sat, AsrOptions options,
                           std::unique_ptr<AsrEngine> engine)
    : loop_(loop),
      sat_(sat),
      options_(std::move(options)),
      transcript_(options_.name + ".transcript"),
      control_(options_.name + ".control"),
      engine_name_(engine->name()),
      segmenter_(options_.segmenter,
                 SegmenterSink{
                     .start =
                         [this](const UtteranceBounds& b) {
                           recognizer_->begin(b);
                           announceStart(b);
                         },
                     .audio = [this](std::span<const std::int16_t> s) { recognizer_->audio(s); },
                     .end = [this](const UtteranceBounds& b) { recognizer_->end(b); },
                 }) {
  auto alive = alive_;
  recognizer_ = std::make_unique<Recognizer>(
      std::move(engine),
      [this, alive](Heard heard) {
        loop_.post([this, alive, h = std::move(heard)]() mutable {
          if (alive->load()) onHeard(std::move(h));
        });
      },
      static_cast<std::size_t>(options_.max_queued_s * kEngineRateHz));

  // The starting grammar, if any: compiled on the worker before the first utterance.
  if (!options_.grammar_jsgf.empty() || !options_.keywords.empty()) {
    mode_ = "grammar";
    last_grammar_ = options_.grammar_jsgf;
    const auto jsgf = options_.grammar_jsgf;
    const auto keywords = options_.keywords;
    recognizer_->command([jsgf, keywords](AsrEngine& e) {
      auto r = jsgf.empty() ? e.setKeywords(keywords) : e.setGrammar(jsgf);
      if (!r) log::error(kLog, "ASR-GRAMMAR", "the starting grammar: " + r.error().message);
    });
  }

  const flow::Variant::Map props{
      {"instance", flow::Variant(options_.name)},
      {"engine", flow::Variant(engine_name_)},
      {"input", flow::Variant(options_.input)},
      {"hangover_ms", flow::Variant(static_cast<std::int64_t>(options_.segmenter.vad.hangover_ms))},
      {"max_utterance_s", flow::Variant(options_.segmenter.max_utterance_s)},
  };
  if (auto r = sat_.addChannel({.name = transcript_, .mime = "application/json", .props = props});
      !r) {
    log::error(kLog, "ASR-CHANNEL", r.error().message);
  }
  flow::Variant::Map control_props{
      {"commands", flow::Variant("set_grammar set_mode pause resume status recognise")},
      {"instance", flow::Variant(options_.name)}};
  if (auto r = sat_.addChannel({.name = control_,
                                .kind = flow::ChannelKind::service,
                                .mime = "application/json",
                                .props = control_props});
      !r) {
    log::error(kLog, "ASR-CHANNEL", r.error().message);
  }

  sat_.subscribed.connect(&sat_, [this](const sat::ChannelInfo& info) { onSubscribed(info); });
  sat_.channelChanged.connect(&sat_, [this](const sat::ChannelInfo& info) {
    if (info.id == input_id_ && input_id_ != 0) checkProperties(info.props);
  });
  sat_.dataView.connect(
      &sat_, [this](std::uint16_t id, std::string_view payload) { onData(id, payload); });
  sat_.serviceRequest.connect(&sat_, [this](const sat::Request& r) { onRequest(r); });
  sat_.subscribe(options_.input);
}

AsrSatellite::~AsrSatellite() {
  alive_->store(false);
  recognizer_.reset();  // joins the worker: no result is posted after this
}

void AsrSatellite::onSubscribed(const sat::ChannelInfo& info) {
  if (info.name != options_.input) return;
  input_id_ = info.id;
  have_stream_ = false;  // a new channel instance: its sample counter starts again
  if (info.mime != "audio/L16") {
    log::warn(kLog, "ASR-FORMAT",
              options_.input + " has mime \"" + info.mime +
                  "\", not audio/L16: reading its "
                  "frames anyway (media frames of PCM are accepted)");
  }
  checkProperties(info.props);
  log::info(kLog, "ASR-INPUT",
            "listening to " + info.name + " " + flow::variantToJsonText(info.props));
}

void AsrSatellite::checkProperties(const flow::Variant& props) {
  std::string problem;
  if (const auto* f = props.find("format")) {
    const auto* s = f->asString();
    if (s == nullptr || *s != "s16le") {
      problem = "format " + flow::variantToJsonText(*f) + " (only s16le)";
    }
  }
  if (const auto* c = props.find("channels")) {
    const auto n = c->asInt64();
    if (!n || *n != 1) problem = "channels " + flow::variantToJsonText(*c) + " (only 1)";
  }
  if (const auto* r = props.find("sample_rate")) {
    const auto n = r->asInt64();
    if (!n || *n < kMinRateHz || *n > kMaxRateHz) {
      problem = "sample_rate " + flow::variantToJsonText(*r) + " (8000..192000)";
    }
  }
  const bool was_ok = props_ok_;
  props_ok_ = problem.empty();
  if (!props_ok_) {
    log::error(kLog, "ASR-FORMAT",
               options_.input + ": " + problem + ": its audio is ignored until that changes");
    segmenter_.flush();
  } else if (!was_ok) {
    log::info(kLog, "ASR-FORMAT", options_.input + ": properties fine again, listening");
  }
}

void AsrSatellite::ignore(const std::string& reason) {
  ++counters_.ignored;
  // One line per kind of trouble, not per frame.
  if (reason != last_ignored_) {
    log::warn(kLog, "ASR-IGNORED", options_.input + ": " + reason + " (frames ignored)");
    last_ignored_ = reason;
  }
}

void AsrSatellite::rebase(std::uint64_t seq, std::uint32_t rate, std::int64_t capture_ns) {
  if (!resampler_ || resampler_->inRate() != rate) {
    resampler_.emplace(rate, kEngineRateHz);
  } else {
    resampler_->reset();
  }
  rate_ = rate;
  base16_ = pushed16_;
  base_s_ =
      capture_ns != 0 ? static_cast<double>(capture_ns) * 1e-9 : static_cast<double>(seq) / rate;
}

double AsrSatellite::clockAt(std::uint64_t sample16) const noexcept {
  return base_s_ + (static_cast<double>(sample16) - static_cast<double>(base16_)) / kEngineRateHz;
}

void AsrSatellite::onData(std::uint16_t id, std::string_view payload) {
  if (id != input_id_ || input_id_ == 0) return;
  ++counters_.frames;
  if (!props_ok_) {
    ++counters_.ignored;
    return;
  }
  const auto frame = media::parseFrame(payload);
  if (!frame || frame->header.format != media::Format::pcm_s16le) {
    ignore("not a PCM media frame (docs/channels.md)");
    return;
  }
  const auto& h = frame->header;
  if (h.channels != 1) {
    ignore(std::to_string(h.channels) + " channels in the frame (only mono)");
    return;
  }
  if (h.sample_rate < kMinRateHz || h.sample_rate > kMaxRateHz) {
    ignore("sample rate " + std::to_string(h.sample_rate) + " Hz in the frame (8000..192000)");
    return;
  }
  last_ignored_.clear();
  const std::size_t n = frame->payload.size() / 2;
  const bool continuous = have_stream_ && h.seq == expected_seq_ && h.sample_rate == rate_;
  expected_seq_ = h.seq + n;
  if (paused_) {
    have_stream_ = false;  // resume starts a new stretch of audio
    return;
  }
  if (!continuous) {
    if (have_stream_) {
      ++counters_.gaps;
      segmenter_.flush();
    }
    rebase(h.seq, h.sample_rate, h.capture_ns);
    have_stream_ = true;
  }
  // Samples are little-endian in the payload; copy out (the payload may be unaligned).
  std::vector<std::int16_t> in(n);
  const auto* bytes = reinterpret_cast<const unsigned char*>(frame->payload.data());
  for (std::size_t i = 0; i < n; ++i) {
    in[i] = static_cast<std::int16_t>(bytes[2 * i] | (bytes[2 * i + 1] << 8));
  }
  out16_.clear();
  resampler_->process(in, out16_);
  pushed16_ += out16_.size();
  segmenter_.push(out16_);
}

// {"event": "started", ...} on the transcript channel: an utterance begins here (the agent
// keeps its audio until the transcript comes, docs/agent.md).
void AsrSatellite::announceStart(const UtteranceBounds& b) {
  const flow::Variant event = flow::Variant::Map{
      {"event", flow::Variant("started")},
      {"instance", flow::Variant(options_.name)},
      {"utterance", flow::Variant(static_cast<std::int64_t>(recognizer_->lastBegun()))},
      {"start", flow::Variant(clockAt(b.speech_start))}};
  if (auto r = sat_.publish(transcript_, flow::variantToJsonText(event)); !r) {
    log::warn(kLog, "ASR-PUBLISH", r.error().message);
  }
}

void AsrSatellite::recogniseGiven(const sat::Request& request, const flow::Variant::Map& value) {
  const auto field = [&](const char* key) -> const flow::Variant* {
    auto it = value.find(key);
    return it == value.end() ? nullptr : &it->second;
  };
  const flow::Variant* audio = field("audio");
  const flow::Variant* rate = field("sample_rate");
  const flow::Variant* start = field("start");
  const std::int64_t hz = rate != nullptr ? rate->asInt64().value_or(0) : 0;
  if (audio == nullptr || audio->asBytes() == nullptr || hz < kMinRateHz || hz > kMaxRateHz) {
    (void)sat_.respond(request, errorValue("recognise takes {\"audio\": bytes (PCM s16le mono), "
                                           "\"sample_rate\": 8000..192000, \"start\": s}"));
    return;
  }
  if (segmenter_.inUtterance()) {
    (void)sat_.respond(request, errorValue("busy: an utterance of the stream is under way"));
    return;
  }
  const std::string& bytes = audio->asBytes()->data;
  std::vector<std::int16_t> in(bytes.size() / 2), out;
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  for (std::size_t i = 0; i < in.size(); ++i) {
    in[i] = static_cast<std::int16_t>(b[2 * i] | (b[2 * i + 1] << 8));
  }
  Resampler(static_cast<std::uint32_t>(hz), kEngineRateHz).process(in, out);
  UtteranceBounds bounds;
  bounds.speech_end = bounds.decided_at = out.size();
  recognizer_->begin(bounds);
  const std::uint64_t n = recognizer_->lastBegun();
  given_[n] = start != nullptr ? start->asDouble().value_or(0) : 0;
  recognizer_->audio(out);
  recognizer_->end(bounds);
  log::info(kLog, "ASR-GIVEN",
            "utterance " + std::to_string(n) + ": " + std::to_string(out.size()) +
                " samples handed over by " + request.requester);
  (void)sat_.respond(
      request, flow::Variant::Map{{"ok", flow::Variant(true)},
                                  {"utterance", flow::Variant(static_cast<std::int64_t>(n))}});
}

void AsrSatellite::onHeard(Heard heard) {
  TranscriptFields t;
  t.instance = options_.name;
  t.mode = modeName(heard.mode);
  t.utterance = heard.utterance;
  // A handed-over utterance is timed from where its audio started; the stream's by its clock.
  std::function<double(std::uint64_t)> at = [this](std::uint64_t s) { return clockAt(s); };
  if (auto given = given_.find(heard.utterance); given != given_.end()) {
    at = [origin = given->second](std::uint64_t s) {
      return origin + static_cast<double>(s) / kEngineRateHz;
    };
    given_.erase(given);
  }
  t.start_s = at(heard.bounds.speech_start);
  t.end_s = at(heard.bounds.speech_end);
  t.decided_s = at(heard.bounds.decided_at);
  t.audio_start_s = at(heard.bounds.audio_start);
  t.cut = heard.bounds.cut;
  t.engine_ms = heard.engine_ms;
  if (heard.bounds.cut) ++counters_.cut;
  if (heard.dropped) {
    ++counters_.dropped;
    t.dropped = true;
    t.rejected = true;
    log::warn(kLog, "ASR-DROPPED",
              "utterance " + std::to_string(heard.utterance) +
                  " not recognised: the recogniser is too far behind");
  } else if (!heard.result) {
    ++counters_.errors;
    t.error = heard.result.error().message;
    t.rejected = true;
    log::error(kLog, "ASR-ENGINE", heard.result.error().describe());
  } else {
    t.result = std::move(heard.result).value();
    t.rejected = t.result.rejected;
    if (t.rejected) ++counters_.rejected;
  }
  ++counters_.utterances;
  const std::string json = transcriptJson(t);
  log::info(kLog, "ASR-HEARD", json);
  if (auto r = sat_.publish(transcript_, json); !r) {
    log::warn(kLog, "ASR-PUBLISH", r.error().message);
  }
}

void AsrSatellite::respondLater(const sat::Request& request,
                                std::function<Result<void>(AsrEngine&)> fn,
                                std::string mode_after) {
  auto alive = alive_;
  recognizer_->command([this, alive, request, fn = std::move(fn),
                        mode_after = std::move(mode_after)](AsrEngine& engine) {
    auto r = fn(engine);
    loop_.post([this, alive, request, r = std::move(r), mode_after] {
      if (!alive->load()) return;
      if (!r) {
        log::warn(kLog, "ASR-CONTROL", request.command + ": " + r.error().message);
        (void)sat_.respond(request, errorValue(r.error().message));
        return;
      }
      mode_ = mode_after;
      log::info(kLog, "ASR-MODE", "now in " + mode_ + " mode");
      (void)sat_.respond(
          request, flow::Variant::Map{{"ok", flow::Variant(true)}, {"mode", flow::Variant(mode_)}});
    });
  });
}

void AsrSatellite::onRequest(const sat::Request& request) {
  const std::string& cmd = request.command;
  if (cmd == "status") {
    (void)sat_.respond(request, status());
    return;
  }
  if (cmd == "pause" || cmd == "resume") {
    const bool pause = cmd == "pause";
    if (pause && !paused_) segmenter_.flush();  // what was heard so far is still recognised
    paused_ = pause;
    have_stream_ = false;
    log::info(kLog, "ASR-PAUSE", pause ? "paused" : "listening again");
    (void)sat_.respond(request, flow::Variant::Map{{"ok", flow::Variant(true)},
                                                   {"paused", flow::Variant(paused_)}});
    return;
  }
  const auto value = valueMap(request.value);
  if (cmd == "recognise") {
    if (!value) {
      (void)sat_.respond(request, errorValue("recognise takes {\"audio\", \"sample_rate\", "
                                             "\"start\"}"));
      return;
    }
    recogniseGiven(request, *value->asMap());
    return;
  }
  if (cmd == "set_grammar") {
    if (!value) {
      (void)sat_.respond(request, errorValue("set_grammar takes {\"jsgf\": text} or "
                                             "{\"keywords\": [phrases]}"));
      return;
    }
    if (const auto* jsgf = value->find("jsgf"); jsgf != nullptr && jsgf->asString() != nullptr) {
      const std::string text = *jsgf->asString();
      last_grammar_ = text;
      respondLater(
          request, [text](AsrEngine& e) { return e.setGrammar(text); }, "grammar");
      return;
    }
    if (const auto* kw = value->find("keywords"); kw != nullptr && kw->asList() != nullptr) {
      std::vector<std::string> phrases;
      for (const auto& p : *kw->asList()) {
        if (const auto* s = p.asString()) phrases.push_back(*s);
      }
      last_grammar_.clear();
      respondLater(
          request, [phrases](AsrEngine& e) { return e.setKeywords(phrases); }, "grammar");
      return;
    }
    (void)sat_.respond(request, errorValue("set_grammar takes {\"jsgf\": text} or "
                                           "{\"keywords\": [phrases]}"));
    return;
  }
  if (cmd == "set_mode") {
    const flow::Variant* m = value ? value->find("mode") : nullptr;
    const std::string* mode = m != nullptr ? m->asString() : request.value.asString();
    if (mode != nullptr && *mode == "dictation") {
      respondLater(
          request, [](AsrEngine& e) { return e.setDictation(); }, "dictation");
      return;
    }
    if (mode != nullptr && *mode == "grammar") {
      if (last_grammar_.empty()) {
        (void)sat_.respond(request, errorValue("no grammar yet: send set_grammar"));
        return;
      }
      const std::string text = last_grammar_;
      respondLater(
          request, [text](AsrEngine& e) { return e.setGrammar(text); }, "grammar");
      return;
    }
    (void)sat_.respond(request, errorValue("set_mode takes {\"mode\": \"dictation\"|\"grammar\"}"));
    return;
  }
  (void)sat_.respond(request, errorValue("unknown command \"" + cmd +
                                         "\" (set_grammar, set_mode, pause, resume, status, "
                                         "recognise)"));
}

flow::Variant AsrSatellite::status() const {
  const bool busy = recognizer_->busy() || segmenter_.inUtterance();
  const auto u = [](std::uint64_t v) { return flow::Variant(static_cast<std::int64_t>(v)); };
  return flow::Variant::Map{
      {"instance", flow::Variant(options_.name)},
      {"engine", flow::Variant(engine_name_)},
      {"state", flow::Variant(paused_ ? "paused"
                              : busy  ? "busy"
                                      : "idle")},
      {"busy", flow::Variant(busy)},
      {"paused", flow::Variant(paused_)},
      {"in_speech", flow::Variant(segmenter_.inUtterance())},
      {"mode", flow::Variant(mode_)},
      {"utterances", u(counters_.utterances)},
      {"rejected", u(counters_.rejected)},
      {"cut", u(counters_.cut)},
      {"dropped", u(counters_.dropped)},
      {"errors", u(counters_.errors)},
      {"frames", u(counters_.frames)},
      {"ignored", u(counters_.ignored)},
      {"gaps", u(counters_.gaps)},
      {"queued_s",
       flow::Variant(static_cast<double>(recognizer_->queuedSamples()) / kEngineRateHz)},
      {"hangover_ms", flow::Variant(static_cast<std::int64_t>(options_.segmenter.vad.hangover_ms))},
  };
}

}  // namespace skr::asr
