// SPDX-License-Identifier: Apache-2.0
// speech: text to speech with espeak-ng, and the phoneme timeline that moves a face's lips
// (docs/audio.md).
//   <name>.say       service, command "say", value {"text","voice","rate","pitch"}
//   <name>.voice     PCM media frames; seq is a sample counter that runs across utterances
//   <name>.phonemes  one JSON timeline per utterance, published before its first audio frame
// Requests queue (bounded) for one worker thread that owns espeak-ng (global state: it is never
// called from the loop thread). The worker posts each finished utterance to the loop thread,
// which publishes the timeline, then all the audio at once (faster than real time; consumers
// play by the sample counter), then answers the request.
#include <skrobot/audio/bounded_queue.h>
#include <skrobot/audio/pcm_output.h>
#include <skrobot/support/pin_library.hpp>
#include "synthesizer.h"
#include "utterance_json.h"

#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>

#include <espeak-ng/speak_lib.h>

#include <memory>
#include <string>
#include <thread>
#include <variant>

namespace {

// espeak-ng stays initialised, so mapped, for the process's life (synthesizer.cpp,
// pin_library.hpp).
[[maybe_unused]] const bool kEspeakPinned = skr::support::pinLoadedLibrary("libespeak-ng.so.1");

using skr::plugin::Host;

// A say request is one flat object: shallow, and bounded by the hub's message size anyway.
constexpr skr::support::JsonLimits kRequestLimits{8, 1u << 20};

struct Job {
  std::uint64_t request = 0;  // the service request to answer
  std::uint64_t utterance = 0;
  std::string text;
  skr::speech::Voice voice;
};

class Speech final : public skr::plugin::Module {
 public:
  // The host has checked the config against kConfig and filled in the defaults.
  explicit Speech(Host& host)
      : host_(host),
        voice_(host.configString("voice")),
        rate_(static_cast<int>(host.configInt("rate"))),
        pitch_(static_cast<int>(host.configInt("pitch"))),
        max_text_(static_cast<std::size_t>(host.configInt("max_text"))),
        frame_samples_(static_cast<std::size_t>(host.configInt("frame_samples"))),
        queue_(static_cast<std::size_t>(host.configInt("queue_max"))) {}

  void start() override {
    using namespace skr::plugin;
    voice_out_ = StreamChannel(host_, "voice", skr::audio::pcmMime(),
                               skr::audio::audioProps(skr::audio::kDefaultRate, 1));
    phonemes_ = StreamChannel(host_, "phonemes", "application/json", "{}");
    say_ = ServiceChannel(host_, "say", [this](const ServiceRequest& r) { onSay(r); });
    worker_ = std::thread([this] { work(); });
  }

  void stop() override {
    queue_.close();
    if (worker_.joinable()) worker_.join();
    say_.reset();
    phonemes_.reset();
    voice_out_.reset();
  }

 private:
  void onSay(const skr::plugin::ServiceRequest& r) {
    auto fail = [&](const std::string& why) { say_.respond(r.id, skr::speech::errorJson(why)); };
    if (r.command != "say") return fail("unknown command '" + r.command + "' (use \"say\")");
    const auto value = skr::support::parseJson(r.value_json, kRequestLimits);
    if (!value) return fail("the value is not JSON: " + value.error().message);
    Job job;
    job.voice = {voice_, rate_, pitch_};
    if (value->isString()) {
      job.text = value->asString();
    } else if (value->isObject()) {
      const Json::Value& v = *value;
      if (!v["text"].isString()) return fail("\"text\" must be a string");
      job.text = v["text"].asString();
      if (v.isMember("voice")) {
        if (!v["voice"].isString() || v["voice"].asString().empty()) {
          return fail("\"voice\" must be a voice name");
        }
        job.voice.name = v["voice"].asString();
      }
      if (v.isMember("rate")) {
        if (!v["rate"].isNumeric()) return fail("\"rate\" must be a number");
        const double rate = v["rate"].asDouble();
        if (rate < espeakRATE_MINIMUM || rate > espeakRATE_MAXIMUM) {
          return fail("\"rate\" must be 80..450 words per minute");
        }
        job.voice.rate_wpm = static_cast<int>(rate);
      }
      if (v.isMember("pitch")) {
        if (!v["pitch"].isNumeric()) return fail("\"pitch\" must be a number");
        const double pitch = v["pitch"].asDouble();
        if (pitch < 0 || pitch > 100) return fail("\"pitch\" must be 0..100");
        job.voice.pitch = static_cast<int>(pitch);
      }
    } else {
      return fail("the value must be {\"text\": ...} or a string");
    }
    if (job.text.find_first_not_of(" \t\r\n") == std::string::npos) return fail("empty text");
    if (job.text.size() > max_text_) {
      return fail("text too long: " + std::to_string(job.text.size()) + " bytes, the limit is " +
                  std::to_string(max_text_));
    }
    job.request = r.id;
    job.utterance = next_utterance_;
    if (!queue_.push(std::move(job))) {
      return fail("busy: " + std::to_string(queue_.capacity()) + " requests are queued already");
    }
    ++next_utterance_;
  }

  // Worker thread: the only one that touches espeak-ng.
  void work() {
    skr::speech::Synthesizer synth;
    if (!synth.ok()) {
      host_.log.error("SPEECH-INIT", synth.error(), "; requests will be refused");
    } else {
      host_.log.info("SPEECH-START", "espeak-ng at ", synth.sampleRate(), " Hz, voice '", voice_,
                     "', ", rate_, " wpm");
    }
    while (auto job = queue_.pop()) {
      const std::int64_t t0 = host_.nowNs();
      auto result = synth.say(job->text, job->voice);
      const std::int64_t synth_ns = host_.nowNs() - t0;
      auto shared =
          std::make_shared<std::pair<Job, decltype(result)>>(std::move(*job), std::move(result));
      host_.post([this, shared, synth_ns] { finish(shared->first, shared->second, synth_ns); });
    }
  }

  // Loop thread: timeline, then audio, then the answer.
  void finish(const Job& job, const std::variant<skr::speech::Utterance, std::string>& result,
              std::int64_t synth_ns) {
    if (const auto* error = std::get_if<std::string>(&result)) {
      host_.log.warn("SPEECH-FAILED", "utterance ", job.utterance, ": ", *error);
      say_.respond(job.request, skr::speech::errorJson(*error));
      return;
    }
    const auto& u = std::get<skr::speech::Utterance>(result);
    if (u.sample_rate != writer_.sampleRate()) {
      writer_.setFormat(u.sample_rate, 1);
      skr::plugin::dbSet(host_, voice_out_.name(), "sample_rate", std::to_string(u.sample_rate));
    }
    phonemes_.publish(
        skr::speech::phonemesJson(job.utterance, writer_.nextSeq(), u, job.text, job.voice.name));
    for (std::size_t at = 0; at < u.samples.size(); at += frame_samples_) {
      const std::size_t n = std::min(frame_samples_, u.samples.size() - at);
      voice_out_.publish(writer_.frame(u.samples.data() + at, n));
    }
    say_.respond(job.request, skr::speech::responseJson(job.utterance, u));
    host_.log.debug("SPEECH-SAID", "utterance ", job.utterance, ": ", u.durationMs(), " ms in ",
                    synth_ns / 1'000'000, " ms, ", u.phonemes.size(), " phonemes");
  }

  Host& host_;
  std::string voice_;
  int rate_;
  int pitch_;
  std::size_t max_text_;
  std::size_t frame_samples_;
  skr::audio::BoundedQueue<Job> queue_;
  skr::audio::PcmWriter writer_{skr::audio::kDefaultRate, 1};
  std::uint64_t next_utterance_ = 1;
  skr::plugin::StreamChannel voice_out_;
  skr::plugin::StreamChannel phonemes_;
  skr::plugin::ServiceChannel say_;
  std::thread worker_;
};

}  // namespace

// rate's range is espeak-ng's (espeakRATE_MINIMUM..espeakRATE_MAXIMUM, espeakRATE_NORMAL).
static_assert(espeakRATE_MINIMUM == 80 && espeakRATE_MAXIMUM == 450 && espeakRATE_NORMAL == 175);
namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    cfg::string("voice", "en", "default espeak-ng voice: a name, file or language (en, it)")
        .nonEmpty(),
    cfg::integer("rate", "175", "default words per minute").range(80, 450),
    cfg::integer("pitch", "50", "default pitch").range(0, 100),
    cfg::integer("max_text", "2000", "longest text accepted, in bytes").range(1, 100000),
    cfg::integer("queue_max", "8",
                 "requests waiting for the synthesizer; beyond it they are refused")
        .range(1, 1000),
    cfg::integer("frame_samples", "1024", "samples per frame on <name>.voice").range(64, 65536),
};

SKR_MODULE_WITH_CONFIG(Speech, "speech", "1.0.0", "espeak-ng speech with a phoneme timeline", 0,
                       kConfig)
