// SPDX-License-Identifier: Apache-2.0
// agent: the robot agent's loop (docs/agent.md). It hears the transcripts of every recogniser
// (channels matching `recognisers`, "<instance>.transcript"), matches them against the intents
// of its rules file, and acts: the avatar speaks (`say`), shows an expression, the Nao moves,
// services are called, databases written. It greets a face that appears after a while with
// none, reads codes aloud, answers "what do you see" from the last detections, hands its command
// grammar to each recogniser (`<instance>.control`, "set_grammar") and pauses them while the
// avatar speaks, so that the robot does not hear itself. It keeps the last seconds of the
// microphone (`mic`): when a recogniser that announced an utterance ("started") leaves before its
// transcript, the utterance's audio goes to another recogniser ("recognise").
//   <name>.dialogue  stream: one JSON per utterance heard or event, with what it answered
//   <name>.command   service: "hear" {"text"} (as if heard), "grammar", "state"
//   database <name>: heard, intent, answer, and what "remember" actions keep
// Log tags: AGENT-RULES, AGENT-HEARD, AGENT-ACTION, AGENT-RECOGNISER, AGENT-REQUEUE.
#include "rules.h"

#include <skrobot/runtime/flow/name_pattern.h>
#include <skrobot/media_frame.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/plugin_watch.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <deque>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace {

using skr::plugin::Host;
using skr::support::writeJson;

// Detections and transcripts are small, flat JSON.
constexpr skr::support::JsonLimits kMessageLimits{8, 1u << 20};
constexpr std::int64_t kNsPerMs = 1'000'000;

// A dialogue entry (docs/agent.md), as the dialogue channel declares it (docs/channels.md):
// something heard (heard, instance, intent or null, slots, answer, or ignored and why) or an
// event (face_appeared, code_seen with its code) and what the agent said to it.
constexpr const char* kDialogueSchema =
    R"({"$schema":"http://json-schema.org/draft-07/schema#","title":"skrobot.agent.Dialogue",)"
    R"("description":"What the agent heard or saw and what it answered, docs/agent.md",)"
    R"("type":"object","anyOf":[{"required":["heard"],"properties":{"heard":{"type":"string"}}},)"
    R"({"required":["event"],"properties":{"event":{"type":"string"}}}],)"
    R"("properties":{"heard":{"type":"string"},"instance":{"type":"string"},)"
    R"("intent":{"type":["string","null"]},"slots":{"type":"object"},)"
    R"("answer":{"type":"string"},"ignored":{"type":"string"},)"
    R"("event":{"type":"string"},"code":{"type":"string"}}})";

// The rules the agent uses when its config names no file (plugins/agent/default-rules.json).
constexpr const char* kDefaultRules =
#include "default_rules.inc"
    ;

struct Recogniser {
  skr::plugin::Subscription transcripts;
  bool has_control = false;
  bool grammar_sent = false;
  std::optional<double> started;  // an utterance it announced and has not transcribed yet
};

// The microphone's last seconds, by the recognisers' audio clock (a frame's capture time, else
// its sample counter over the rate), for an utterance whose recogniser went away.
class AudioRing {
 public:
  explicit AudioRing(double seconds) : seconds_(seconds) {}

  void add(std::string_view message) {
    const auto frame = skr::media::parseFrame(message);
    if (!frame || frame->header.format != skr::media::Format::pcm_s16le ||
        frame->header.channels != 1 || frame->header.sample_rate == 0) {
      return;
    }
    const auto& h = frame->header;
    const double t = h.capture_ns != 0 ? static_cast<double>(h.capture_ns) * 1e-9
                                       : static_cast<double>(h.seq) / h.sample_rate;
    if (!frames_.empty() && frames_.back().rate != h.sample_rate) frames_.clear();
    frames_.push_back({t, h.sample_rate, std::string(frame->payload)});
    while (!frames_.empty() && frames_.back().t - frames_.front().t > seconds_) frames_.pop_front();
  }
  // The samples from `from` on, at most `seconds` of them, and their rate.
  std::pair<std::string, std::uint32_t> from(double t0, double seconds) const {
    std::string pcm;
    std::uint32_t rate = 0;
    for (const Frame& f : frames_) {
      const double end = f.t + static_cast<double>(f.pcm.size() / 2) / f.rate;
      if (end <= t0 || f.t >= t0 + seconds) continue;
      pcm += f.pcm;
      rate = f.rate;
    }
    return {std::move(pcm), rate};
  }
  [[nodiscard]] double latest() const { return frames_.empty() ? 0 : frames_.back().t; }

 private:
  struct Frame {
    double t;
    std::uint32_t rate;
    std::string pcm;
  };
  double seconds_;
  std::deque<Frame> frames_;
};

// A service's answer that says it worked: delivered, and not an object with "error".
bool answered(bool ok, const std::string& answer) {
  if (!ok) return false;
  auto v = skr::support::parseJson(answer, kMessageLimits);
  return !v || !v->isObject() || !v->isMember("error");
}

std::string numberText(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

class Agent final : public skr::plugin::Module {
 public:
  explicit Agent(Host& host)
      : host_(host),
        db_(host.name()),
        say_(host.configString("say")),
        expression_(host.configString("expression")),
        nao_(host.configString("nao")),
        faces_channel_(host.configString("faces")),
        codes_channel_(host.configString("codes")),
        mic_channel_(host.configString("mic")),
        hand_grammar_(host.configBool("hand_grammar")),
        barge_in_(host.configBool("barge_in")),
        greet_after_ns_(host.configInt("greet_after_s") * 1000 * kNsPerMs),
        awake_ns_(host.configInt("awake_s") * 1000 * kNsPerMs),
        code_repeat_ns_(host.configInt("code_repeat_s") * 1000 * kNsPerMs),
        speech_tail_ns_(host.configInt("speech_tail_ms") * kNsPerMs),
        requeue_after_ns_(host.configInt("requeue_after_ms") * kNsPerMs),
        rules_file_(host.configString("rules")) {
    auto pattern = skr::flow::NamePattern::parse(host.configString("recognisers"));
    if (!pattern) {
      host.configError("recognisers", pattern.error().message);
      throw skr::plugin::Failure(SKR_ERR_CONFIG, "recognisers: " + pattern.error().message);
    }
    recognisers_pattern_ = std::move(pattern).value();
    if (rules_file_.empty()) {  // the default rules, compiled in
      auto rules = skr::agent::parseRules(kDefaultRules, "the default rules");
      if (!rules) throw skr::plugin::Failure(SKR_ERR_CONFIG, rules.error().message);
      rules_ = std::move(rules).value();
      grammar_ = rules_.grammar();
      ready_ = true;
    }
  }
  Agent(const Agent&) = delete;
  Agent& operator=(const Agent&) = delete;
  Agent(Agent&&) = delete;
  Agent& operator=(Agent&&) = delete;
  ~Agent() override { forgetLoader(); }

  void start() override {
    using namespace skr::plugin;
    Json::Value dialogue(Json::objectValue);
    skr::support::addTypeProperties(
        dialogue, {"json", "skrobot.agent.Dialogue", "jsonschema", kDialogueSchema});
    dialogue_ = StreamChannel(host_, "dialogue", "application/json", writeJson(dialogue));
    command_ = ServiceChannel(
        host_, "command", [this](const ServiceRequest& r) { onCommand(r); },
        R"({"commands":["hear","grammar","state"]})");
    if (ready_) return listen();
    // The rules file is read and parsed on a thread of its own, never on the loop: commands
    // wait for it (held), the rest starts once it is in (listen); a bad one fails the module.
    // The thread is detached (a read may block, on a FIFO say): it posts through `loader_`,
    // which stop() closes first.
    loader_ = std::make_shared<Loader>();
    loader_->host = &host_;
    std::thread([this, loader = loader_, file = rules_file_] {
      auto rules = readRules(file);
      std::lock_guard lock(loader->mutex);
      if (loader->host == nullptr) return;  // stopped meanwhile
      loader->host->post(
          [this, rules = std::move(rules)]() mutable { rulesRead(std::move(rules)); });
    }).detach();
  }

  void stop() override {
    forgetLoader();
    tick_.reset();
    watch_.reset();
    recognisers_.clear();
    faces_.reset();
    codes_.reset();
    mic_.reset();
    command_.reset();
    dialogue_.reset();
    requester_.reset();
    held_.clear();
  }

 private:
  static skr::Result<skr::agent::Rules> readRules(const std::string& file) {
    std::ifstream in(file);
    std::ostringstream all;
    all << in.rdbuf();
    if (!in) return skr::makeError(skr::Errc::io_error, "cannot read the rules file " + file);
    return skr::agent::parseRules(all.str(), file);
  }

  // What the thread that reads the rules file posts through; host null once stopped.
  struct Loader {
    std::mutex mutex;
    skr::plugin::Host* host = nullptr;
  };
  void forgetLoader() {
    if (!loader_) return;
    std::lock_guard lock(loader_->mutex);
    loader_->host = nullptr;
  }

  // The loop thread: the rules file's contents, or why there are none.
  void rulesRead(skr::Result<skr::agent::Rules> rules) {
    if (!rules) {
      host_.configError("rules", rules.error().message);
      host_.fail(rules.error().message);
      return;
    }
    rules_ = std::move(rules).value();
    grammar_ = rules_.grammar();
    ready_ = true;
    listen();
    for (const auto& r : std::exchange(held_, {})) onCommand(r);
  }

  // Starts hearing, watching and acting (once the rules are in).
  void listen() {
    using namespace skr::plugin;
    requester_ = std::make_unique<Requester>(host_);
    if (!faces_channel_.empty()) {
      faces_ = Subscription(host_, faces_channel_, [this](std::string_view p) { onFaces(p); });
    }
    if (!codes_channel_.empty()) {
      codes_ = Subscription(host_, codes_channel_, [this](std::string_view p) { onCodes(p); });
    }
    if (!mic_channel_.empty()) {
      mic_ = Subscription(host_, mic_channel_, [this](std::string_view p) { ring_.add(p); });
    }
    watch_ = ChannelWatch(host_, [this](const ChannelEvent& ev) { onChannel(ev); });
    tick_ = host_.onTick(Tick::fast, [this] {
      checkSpeaking();
      requeueDue();
    });
    host_.log.info("AGENT-RULES", rules_.intents.size(), " intents, wake phrase '", wakePhrase(),
                   "', ", rules_file_.empty() ? "default rules" : rules_file_);
  }

  std::string wakePhrase() const {
    std::string out;
    for (const std::string& w : rules_.wake_phrase) out += (out.empty() ? "" : " ") + w;
    return out;
  }

  // --- recognisers: "<instance>.transcript" streams, "<instance>.control" services
  void onChannel(const skr::plugin::ChannelEvent& ev) {
    const size_t dot = ev.name.rfind('.');
    if (dot == std::string::npos) return;
    const std::string instance = ev.name.substr(0, dot);
    if (ev.kind == SKR_CHANNEL_SERVICE &&
        ev.name.compare(dot, std::string::npos, ".control") == 0) {
      controls_[instance] = ev.added;
      if (auto it = recognisers_.find(instance); it != recognisers_.end()) {
        it->second.has_control = ev.added;
        it->second.grammar_sent = false;
        if (ev.added) handOver(instance, it->second);
      }
      return;
    }
    if (ev.kind != SKR_CHANNEL_STREAMING || !recognisers_pattern_.matches(ev.name)) return;
    if (!ev.added) {
      auto gone = recognisers_.find(instance);
      if (gone == recognisers_.end()) return;
      if (gone->second.started && !mic_channel_.empty()) {
        // Its utterance, once the speaker has had time to finish it, goes to another one.
        requeue_.push_back({instance, *gone->second.started, host_.nowNs() + requeue_after_ns_});
      }
      recognisers_.erase(gone);
      host_.log.info("AGENT-RECOGNISER", instance, " gone");
      return;
    }
    if (recognisers_.count(instance) != 0) return;
    Recogniser& r = recognisers_[instance];
    r.transcripts = skr::plugin::Subscription(
        host_, ev.name, [this, instance](std::string_view p) { onTranscript(instance, p); });
    r.has_control = controls_[instance];
    host_.log.info("AGENT-RECOGNISER", instance, " listening",
                   r.has_control ? "" : " (no control service yet)");
    if (r.has_control) handOver(instance, r);
  }

  void handOver(const std::string& instance, Recogniser& r) {
    if (!hand_grammar_ || r.grammar_sent) return;
    r.grammar_sent = true;
    Json::Value v(Json::objectValue);
    v["jsgf"] = grammar_;
    requester_->request(instance + ".control", "set_grammar", writeJson(v),
                        [this, instance](bool ok, const std::string& answer) {
                          if (!ok)
                            host_.log.warn("AGENT-RECOGNISER", instance,
                                           " refused the grammar: ", answer);
                        });
    if (speaking_ && !barge_in_) requester_->request(instance + ".control", "pause", "{}");
  }

  void toRecognisers(const char* command) {
    for (auto& [instance, r] : recognisers_) {
      if (r.has_control) requester_->request(instance + ".control", command, "{}");
    }
  }

  // {"text", "confidence", "start", "end", "rejected", ...}
  void onTranscript(const std::string& instance, std::string_view payload) {
    auto v = skr::support::parseJson(payload, kMessageLimits);
    if (!v || !v->isObject()) {
      host_.log.warn("AGENT-HEARD", instance, ": a transcript that is not a JSON object");
      return;
    }
    if ((*v)["event"].asString() == "started") {  // an utterance begins: keep its start
      if (auto it = recognisers_.find(instance); it != recognisers_.end()) {
        it->second.started = (*v)["start"].asDouble();
      }
      return;
    }
    if (auto it = recognisers_.find(instance); it != recognisers_.end()) it->second.started.reset();
    const std::string text = (*v)["text"].asString();
    if ((*v)["rejected"].asBool() || text.empty()) return;
    if (speaking_ && !barge_in_) {
      ++ignored_while_speaking_;
      host_.log.debug("AGENT-HEARD", instance, " while the avatar spoke, ignored: ", text);
      return;
    }
    // Two recognisers on one microphone hear the same utterance: the first transcript wins.
    const double start = (*v)["start"].asDouble(), end = (*v)["end"].asDouble();
    const std::int64_t now = host_.nowNs();
    if ((*v).isMember("start") && (*v).isMember("end")) {
      for (const Heard& h : recent_) {
        if (h.instance != instance && now - h.at_ns < 10'000 * kNsPerMs && start < h.end &&
            h.start < end) {
          ++duplicates_;
          return;
        }
      }
      recent_.push_back({instance, start, end, now});
      if (recent_.size() > 16) recent_.erase(recent_.begin());
    }
    hear(text, instance);
  }

  // An utterance whose recogniser left: its audio (from the ring) to another recogniser.
  void requeueDue() {
    const std::int64_t now = host_.nowNs();
    while (!requeue_.empty() && requeue_.front().due_ns <= now) {
      const Requeue r = requeue_.front();
      requeue_.pop_front();
      auto other = std::find_if(recognisers_.begin(), recognisers_.end(),
                                [](const auto& e) { return e.second.has_control; });
      auto [pcm, rate] = ring_.from(r.start - kPreRollS, kMaxRequeueS);
      if (other == recognisers_.end() || pcm.empty()) {
        ++requeue_failures_;
        host_.log.warn("AGENT-REQUEUE", "the utterance at ", r.start, " s of ", r.instance,
                       other == recognisers_.end() ? ": no other recogniser" : ": no audio kept");
        continue;
      }
      Json::Value v(Json::objectValue);
      v["audio"] = skr::support::jsonBytes(pcm);
      v["sample_rate"] = rate;
      v["start"] = r.start - kPreRollS;
      const std::string to = other->first;
      host_.log.info("AGENT-REQUEUE", "the utterance at ", r.start, " s of ", r.instance,
                     " (gone) to ", to, ": ", pcm.size() / 2, " samples");
      ++requeued_;
      requester_->request(to + ".control", "recognise", writeJson(v),
                          [this, to](bool ok, const std::string& answer) {
                            if (answered(ok, answer)) return;
                            ++requeue_failures_;
                            host_.log.warn("AGENT-REQUEUE", to, " refused: ", answer);
                          });
    }
  }

  // --- what was heard: wake phrase, intent, actions
  Json::Value hear(const std::string& text, const std::string& source) {
    std::vector<std::string> words = skr::agent::wordsOf(text);
    Json::Value said(Json::objectValue);
    said["heard"] = text;
    said["instance"] = source;
    const std::int64_t now = host_.nowNs();
    const auto& wake = rules_.wake_phrase;
    if (!wake.empty()) {
      const bool woken =
          words.size() >= wake.size() && std::equal(wake.begin(), wake.end(), words.begin());
      if (woken) {
        words.erase(words.begin(), words.begin() + static_cast<long>(wake.size()));
        awake_until_ns_ = now + awake_ns_;
        if (words.empty()) {
          said["intent"] = "woken";
          said["answer"] = run(event("woken"), vars(text, {}), {});
          return publish(said);
        }
      } else if (now > awake_until_ns_) {
        said["ignored"] = "no wake phrase";
        return publish(said);
      }
      awake_until_ns_ = now + awake_ns_;
    }
    host_.log.info("AGENT-HEARD", source, ": ", text);
    skr::agent::Vars v = vars(text, {});
    std::map<std::string, double> numbers;
    Json::Value actions = rules_.fallback;
    if (auto m = rules_.match(words)) {
      said["intent"] = m->intent->name;
      Json::Value slots(Json::objectValue);
      for (const auto& [name, value] : m->slots) {
        v[name] = value.number ? numberText(*value.number) : value.text;
        if (value.number) numbers[name] = *value.number;
        slots[name] = value.number ? Json::Value(*value.number) : Json::Value(value.text);
      }
      said["slots"] = slots;
      actions = m->intent->actions;
    } else {
      said["intent"] = Json::Value();
    }
    said["answer"] = run(actions, v, numbers);
    skr::plugin::dbSet(host_, db_, "heard", writeJson(Json::Value(text)));
    skr::plugin::dbSet(host_, db_, "intent", writeJson(said["intent"]));
    skr::plugin::dbSet(host_, db_, "answer", writeJson(said["answer"]));
    return publish(said);
  }

  Json::Value publish(const Json::Value& said) {
    dialogue_.publish(writeJson(said));
    return said;
  }

  const Json::Value& event(const std::string& name) const {
    static const Json::Value none(Json::arrayValue);
    const auto it = rules_.events.find(name);
    return it == rules_.events.end() ? none : it->second;
  }

  skr::agent::Vars vars(const std::string& heard, const std::string& code) {
    skr::agent::Vars v{{"heard", heard}, {"seen", seen()}, {"code", code}};
    const std::time_t t = std::time(nullptr);
    std::tm local{};
    localtime_r(&t, &local);
    char hhmm[8];
    std::strftime(hhmm, sizeof hhmm, "%H:%M", &local);
    v["time"] = hhmm;
    for (const auto& [key, value] : memory_) v["memory." + key] = value;
    return v;
  }

  // Runs the actions in order; what the avatar says, joined.
  std::string run(const Json::Value& actions, const skr::agent::Vars& v,
                  const std::map<std::string, double>& numbers) {
    std::string answer;
    for (const Json::Value& a : actions) {
      const std::string kind = a.getMemberNames()[0];
      const Json::Value value = skr::agent::fillValue(a[kind], v, numbers);
      if (kind == "say") {
        answer += (answer.empty() ? "" : " ") + value.asString();
        speak(value.asString());
      } else if (kind == "expression") {
        Json::Value e(Json::objectValue);
        e["name"] = value.isString() ? value : value["name"];
        e["weight"] =
            value.isObject() && value.isMember("weight") ? value["weight"] : Json::Value(1.0);
        e["duration_ms"] = value.isObject() && value.isMember("duration_ms") ? value["duration_ms"]
                                                                             : Json::Value(2000);
        call(expression_, "expression", e);
      } else if (kind == "nao") {
        call(nao_, value["command"].asString(), value.get("value", Json::objectValue));
      } else if (kind == "call") {
        call(value["channel"].asString(), value["command"].asString(),
             value.get("value", Json::Value()));
      } else if (kind == "remember") {
        for (const std::string& key : value.getMemberNames()) {
          memory_[key] = value[key].isString() ? value[key].asString() : writeJson(value[key]);
          skr::plugin::dbSet(host_, db_, "memory." + key, writeJson(value[key]));
        }
      } else if (kind == "db") {
        if (!skr::plugin::dbSet(host_, value["database"].asString(), value["key"].asString(),
                                writeJson(value["value"]))) {
          ++action_failures_;
        }
      }
    }
    return answer;
  }

  void call(const std::string& channel, const std::string& command, const Json::Value& value) {
    if (channel.empty()) return;
    const bool sent =
        requester_->request(channel, command, writeJson(value),
                            [this, channel, command](bool ok, const std::string& answer) {
                              if (answered(ok, answer)) return;
                              ++action_failures_;
                              host_.log.warn("AGENT-ACTION", channel, " ", command, ": ", answer);
                            });
    if (!sent) {
      ++action_failures_;
      host_.log.warn("AGENT-ACTION", channel, " is not there: ", command, " not sent");
    }
  }

  // --- speaking: the recognisers pause until the avatar has finished (unless barge_in)
  void speak(const std::string& text) {
    if (say_.empty()) return;
    if (!speaking_ && !barge_in_) toRecognisers("pause");
    speaking_ = true;
    ++says_pending_;
    Json::Value v(Json::objectValue);
    v["text"] = text;
    const bool sent =
        requester_->request(say_, "say", writeJson(v), [this](bool ok, const std::string& answer) {
          --says_pending_;
          auto a = skr::support::parseJson(answer, kMessageLimits);
          const std::int64_t duration_ms =
              ok && a && a->isObject() ? (*a)["duration_ms"].asInt64() : 0;
          if (!ok || duration_ms == 0) {
            ++action_failures_;
            host_.log.warn("AGENT-ACTION", say_, " say: ", answer);
          }
          const std::int64_t from = std::max(host_.nowNs(), speaking_until_ns_);
          speaking_until_ns_ = from + duration_ms * kNsPerMs;
        });
    if (!sent) {
      --says_pending_;
      ++action_failures_;
      host_.log.warn("AGENT-ACTION", say_, " is not there: nothing said");
    }
  }

  void checkSpeaking() {
    if (!speaking_ || says_pending_ > 0) return;
    if (host_.nowNs() < speaking_until_ns_ + speech_tail_ns_) return;
    speaking_ = false;
    speaking_until_ns_ = 0;
    if (!barge_in_) toRecognisers("resume");
  }

  // --- what the robot sees
  void onFaces(std::string_view payload) {
    auto v = skr::support::parseJson(payload, kMessageLimits);
    if (!v || !v->isObject()) return;
    const std::int64_t now = host_.nowNs();
    faces_at_ns_ = now;
    face_count_ = static_cast<int>((*v)["faces"].size());
    if (face_count_ == 0) return;
    const bool greet = last_face_ns_ == 0 || now - last_face_ns_ > greet_after_ns_;
    last_face_ns_ = now;
    if (!greet || event("face_appeared").empty()) return;
    Json::Value said(Json::objectValue);
    said["event"] = "face_appeared";
    said["answer"] = run(event("face_appeared"), vars("", ""), {});
    publish(said);
  }

  void onCodes(std::string_view payload) {
    auto v = skr::support::parseJson(payload, kMessageLimits);
    if (!v || !v->isObject()) return;
    const std::int64_t now = host_.nowNs();
    codes_seen_.clear();
    for (const Json::Value& c : (*v)["codes"]) codes_seen_.push_back(c["text"].asString());
    codes_at_ns_ = now;
    for (const std::string& code : codes_seen_) {
      auto it = codes_read_.find(code);
      if (it != codes_read_.end() && now - it->second < code_repeat_ns_) continue;
      codes_read_[code] = now;
      if (event("code_seen").empty()) continue;
      Json::Value said(Json::objectValue);
      said["event"] = "code_seen";
      said["code"] = code;
      said["answer"] = run(event("code_seen"), vars("", code), {});
      publish(said);
    }
  }

  // "{seen}": the detections of the last two seconds, in words.
  std::string seen() const {
    const std::int64_t now = host_.nowNs();
    const std::int64_t fresh = 2000 * kNsPerMs;
    std::vector<std::string> parts;
    if (faces_at_ns_ != 0 && now - faces_at_ns_ < fresh && face_count_ > 0) {
      parts.push_back(face_count_ == 1 ? "one face" : std::to_string(face_count_) + " faces");
    }
    if (codes_at_ns_ != 0 && now - codes_at_ns_ < fresh) {
      for (const std::string& code : codes_seen_) parts.push_back("a code that says " + code);
    }
    if (parts.empty()) return "I don't see anything I know.";
    std::string out = "I see ";
    for (size_t i = 0; i < parts.size(); ++i) {
      out += (i == 0 ? "" : i + 1 == parts.size() ? " and " : ", ") + parts[i];
    }
    return out + ".";
  }

  // --- agent.command
  void onCommand(const skr::plugin::ServiceRequest& r) {
    if (!ready_) {  // answered once the rules are in
      if (held_.size() < kMaxHeld)
        held_.push_back(r);
      else
        command_.respond(r.id, R"({"error":"the agent is still reading its rules"})");
      return;
    }
    Json::Value answer(Json::objectValue);
    if (r.command == "hear") {
      auto v = skr::support::parseJson(r.value_json, kMessageLimits);
      const Json::Value text = v && v->isObject() ? (*v)["text"] : v ? *v : Json::Value();
      if (!text.isString()) {
        answer["error"] = "hear takes {\"text\": ...}";
      } else {
        answer = hear(text.asString(), r.requester);
      }
    } else if (r.command == "grammar") {
      answer["jsgf"] = grammar_;
    } else if (r.command == "state") {
      answer["speaking"] = speaking_;
      answer["awake"] = rules_.wake_phrase.empty() || host_.nowNs() <= awake_until_ns_;
      Json::Value list(Json::arrayValue);
      for (const auto& [instance, rec] : recognisers_) list.append(instance);
      answer["recognisers"] = list;
      answer["ignored_while_speaking"] = Json::UInt64(ignored_while_speaking_);
      answer["duplicates"] = Json::UInt64(duplicates_);
      answer["action_failures"] = Json::UInt64(action_failures_);
      answer["requeued"] = Json::UInt64(requeued_);
      answer["requeue_failures"] = Json::UInt64(requeue_failures_);
    } else {
      answer["error"] = "unknown command '" + r.command + "' (hear, grammar, state)";
    }
    command_.respond(r.id, writeJson(answer));
  }

  struct Heard {
    std::string instance;
    double start, end;
    std::int64_t at_ns;
  };
  struct Requeue {
    std::string instance;
    double start;
    std::int64_t due_ns;
  };
  static constexpr double kPreRollS = 0.2;      // audio kept before an utterance's start
  static constexpr double kMaxRequeueS = 15.0;  // at most this much of it is sent again

  Host& host_;
  const std::string db_;
  const std::string say_, expression_, nao_, faces_channel_, codes_channel_, mic_channel_;
  const bool hand_grammar_, barge_in_;
  const std::int64_t greet_after_ns_, awake_ns_, code_repeat_ns_, speech_tail_ns_,
      requeue_after_ns_;
  skr::flow::NamePattern recognisers_pattern_;
  const std::string rules_file_;  // empty: the default rules
  skr::agent::Rules rules_;
  std::string grammar_;
  bool ready_ = false;  // rules_ is in
  static constexpr std::size_t kMaxHeld = 64;
  std::vector<skr::plugin::ServiceRequest> held_;  // commands that came before the rules
  std::shared_ptr<Loader> loader_;                 // while the rules file is read

  std::unique_ptr<skr::plugin::Requester> requester_;
  skr::plugin::StreamChannel dialogue_;
  skr::plugin::ServiceChannel command_;
  skr::plugin::Subscription faces_, codes_, mic_;
  AudioRing ring_{30};
  std::deque<Requeue> requeue_;
  skr::plugin::ChannelWatch watch_;
  skr::plugin::TickHandle tick_;
  std::map<std::string, Recogniser> recognisers_;
  std::map<std::string, bool> controls_;  // "<instance>.control" services there are
  std::vector<Heard> recent_;
  std::map<std::string, std::string> memory_;

  bool speaking_ = false;
  int says_pending_ = 0;
  std::int64_t speaking_until_ns_ = 0;
  std::int64_t awake_until_ns_ = 0;
  int face_count_ = 0;
  std::int64_t faces_at_ns_ = 0, last_face_ns_ = 0, codes_at_ns_ = 0;
  std::vector<std::string> codes_seen_;
  std::map<std::string, std::int64_t> codes_read_;
  std::uint64_t ignored_while_speaking_ = 0, duplicates_ = 0, action_failures_ = 0;
  std::uint64_t requeued_ = 0, requeue_failures_ = 0;
};

}  // namespace

constexpr skr_config_key kConfig[] = {
    skr::config::string("rules", "",
                        "the rules file (JSON, docs/agent.md); empty: the default rules"),
    skr::config::string("say", "websocket-ui.say", "the service that speaks (command \"say\")"),
    skr::config::string("expression", "websocket-ui.say",
                        "the service that shows an expression (command \"expression\")"),
    skr::config::string("nao", "nao-bridge.command", "the Nao's command service"),
    skr::config::string("faces", "face-detect.faces",
                        "face detections to greet and describe; empty: none"),
    skr::config::string("codes", "qrcode.codes", "codes to read aloud and describe; empty: none"),
    skr::config::string("recognisers", "**.transcript",
                        "the transcript channels to listen to (a channel-name pattern)"),
    skr::config::boolean("hand_grammar", "true",
                         "hand the rules' command grammar to each recogniser"),
    skr::config::boolean("barge_in", "false", "keep listening while the avatar speaks"),
    skr::config::integer("greet_after_s", "30",
                         "greet a face that appears after this long with none")
        .range(0, 86400),
    skr::config::integer("awake_s", "15", "with a wake phrase: how long the agent listens after it")
        .range(1, 3600),
    skr::config::integer("code_repeat_s", "30", "read the same code aloud again after this long")
        .range(0, 86400),
    skr::config::string("mic", "websocket-ui.mic",
                        "the microphone whose last 30 s are kept for utterances to re-queue; "
                        "empty: none"),
    skr::config::integer("requeue_after_ms", "1500",
                         "how long after a recogniser left its utterance is re-queued")
        .range(0, 60000),
    skr::config::integer("speech_tail_ms", "300",
                         "the recognisers resume this long after the avatar stops")
        .range(0, 10000),
};

SKR_MODULE_WITH_CONFIG(Agent, "agent", "1.0.0",
                       "the robot agent: hears transcripts, matches intents, speaks and acts", 0,
                       kConfig)
