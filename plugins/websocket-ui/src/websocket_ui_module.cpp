// SPDX-License-Identifier: Apache-2.0
// websocket-ui: serves the avatar page and bridges browsers to the FlowNetwork
// (docs/websocket-ui.md).
//
// Browsers connect to an endpoint on the hub's web port (plugin ABI 1.8), or to the module's own
// server when its config names a `port` (browsers.h). Threads: what browsers send is checked
// where it arrives (the loop, or the own server's thread) and handed to the hub's loop thread
// with host.post; everything touching channels runs on the loop.
#include "avatar_behaviour.h"
#include "browser_protocol.h"
#include "browsers.h"
#include "source_owner.h"
#include "visemes.h"
#include "web_root.h"

#include <skrobot/web/ws_server.h>
#include <skrobot/media_frame.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <algorithm>
#include <atomic>
#include <map>
#include <memory>
#include <set>
#include <string>

namespace skr::wsui {
namespace {

using skr::plugin::Failure;
using skr::support::writeJson;

// Detections and timelines from other modules: objects of a few levels.
constexpr skr::support::JsonLimits kChannelLimits{32, 16u << 20};

// The object in a channel's message; nullopt (the message is skipped) for anything else.
std::optional<Json::Value> channelObject(std::string_view payload) {
  auto v = skr::support::parseJsonObject(payload, kChannelLimits);
  if (!v) return std::nullopt;
  return std::move(*v);
}

struct Counters {
  std::uint64_t camera_frames = 0;
  std::uint64_t mic_frames = 0;
  std::uint64_t mic_gaps = 0;
  std::uint64_t say_requests = 0;
};

class WebsocketUi final : public skr::plugin::Module {
 public:
  // The host has checked the config against kConfig (types, ranges) and filled in the defaults.
  explicit WebsocketUi(skr::plugin::Host& host)
      : host_(host),
        avatar_(readAvatar(host)),
        camera_owner_(host.configInt("handover_ms")),
        mic_owner_(host.configInt("handover_ms")) {
    warnRemovedKeys();
    readServer();
    limits_.mic_sample_rate = static_cast<std::uint32_t>(host.configInt("mic_sample_rate"));
    camera_width_ = static_cast<int>(host.configInt("camera_width"));
    camera_height_ = static_cast<int>(host.configInt("camera_height"));
    camera_fps_ = static_cast<int>(host.configInt("camera_fps"));
    jpeg_quality_ = host.configDouble("jpeg_quality");
    light_colour_ = colour(host, "avatar_light");
    eye_colour_ = colour(host, "avatar_eyes");
    // Other modules' channels: named by the config (config/default.json wires the demo), none
    // by default.
    faces_ = host.configString("faces");
    motion_ = host.configString("motion");
    codes_ = host.configString("codes");
    bands_ = host.configString("bands");
    speech_ = host.configString("speech");
    voice_ = host.configString("voice");
    phonemes_ = host.configString("phonemes");
    dialogue_ = host.configString("dialogue");
  }

  void start() override {
    using namespace skr::plugin;
    Json::Value camera(Json::objectValue);
    camera["width"] = camera_width_;
    camera["height"] = camera_height_;
    camera["fps"] = camera_fps_;
    const auto& jpeg = *skr::media::encodingInfo(skr::media::Format::jpeg);
    skr::support::addMediaProperties(camera, jpeg);
    camera_ = StreamChannel(host_, "camera", std::string(jpeg.mime), writeJson(camera));
    Json::Value mic(Json::objectValue);
    mic["sample_rate"] = limits_.mic_sample_rate;
    mic["channels"] = 1;
    const auto& pcm = *skr::media::encodingInfo(skr::media::Format::pcm_s16le);
    skr::support::addMediaProperties(mic, pcm);
    mic_ = StreamChannel(host_, "mic", std::string(pcm.mime), writeJson(mic));
    Json::Value say(Json::objectValue);
    say["commands"] = "say, expression";
    say["value"] =
        "say: {\"text\": string, \"voice\": string}; expression: {\"name\": "
        "\"neutral\"|\"happy\"|\"surprised\"|\"thinking\"|\"listening\"|\"sad\", "
        "\"weight\": 0..1, \"duration_ms\": number}";
    say_ = ServiceChannel(
        host_, "say", [this](const ServiceRequest& r) { onSayRequest(r); }, writeJson(say));
    requester_.emplace(host_);
    subscribe(faces_, [this](std::string_view p) { onFaces(p); });
    subscribe(motion_, [this](std::string_view p) { onMotion(p); });
    subscribe(codes_, [this](std::string_view p) { onCodes(p); });
    subscribe(bands_, [this](std::string_view p) { forward("bands", p); });
    subscribe(dialogue_, [this](std::string_view p) { forward("dialogue", p); });
    subscribe(phonemes_, [this](std::string_view p) { onPhonemes(p); });
    subscribe(voice_, [this](std::string_view p) {
      if (skr::media::parseFrame(p)) broadcast(true, std::string(p), false);
    });

    WsServerEvents events;
    events.log = [this](int level, const std::string& line) {
      const auto space = line.find(' ');
      host_.log.write(static_cast<skr_log_level>(level), line.substr(0, space),
                      space == std::string::npos ? "" : line.substr(space + 1));
    };
    events.opened = [this](std::uint64_t conn, const std::string& peer) {
      server_.send(conn, false, welcome());
      host_.post([this, conn, peer] {
        avatar_pages_.insert(conn);
        host_.log.info("WSUI-BROWSER", "browser ", conn, " connected from ", peer);
      });
    };
    events.closed = [this](std::uint64_t conn, const std::string& why) {
      host_.post([this, conn, why] {
        avatar_pages_.erase(conn);
        mic_expected_.erase(conn);
        camera_owner_.leave(conn);
        mic_owner_.leave(conn);
        host_.log.info("WSUI-BROWSER", "browser ", conn, " left: ", why);
      });
    };
    events.message = [this](std::uint64_t conn, bool binary, std::string&& data,
                            int& code) -> std::optional<std::string> {
      return onBrowserMessage(conn, binary, std::move(data), code);
    };
    if (!host_.configHas("port")) {
      // The hub's web port serves the page (its root) and upgrades /ws to this module.
      try {
        server_.startOnHub(host_, server_opts_, std::move(events));
      } catch (const Failure& e) {
        throw Failure(e.status(),
                      std::string(e.what()) +
                          " (the avatar's WebSocket goes on the hub's web port: set server.web "
                          "in the hub's config, or a `port` for websocket-ui's own server)");
      }
      host_.log.info("WSUI-LISTENING", "avatar WebSocket ", server_opts_.ws_path,
                     " on the hub's web port (server.web)");
    } else {
      if (auto error = server_.startOwn(server_opts_, std::move(events))) {
        throw Failure(SKR_ERR_FAILED, *error);
      }
      host_.log.info("WSUI-LISTENING", "avatar page on ",
                     server_opts_.tls_cert.empty() ? "http" : "https", "://", server_opts_.address,
                     ":", server_.port(), "/ (web root ", server_opts_.web_root, ")");
    }
    fast_ = host_.onTick(skr::plugin::Tick::fast, [this] { behave(); });
    second_ = host_.onTick(skr::plugin::Tick::one_sec, [this] { report(); });
  }

  void stop() override {
    server_.stop();  // joins the own server's thread, or unserves: no more events
    fast_.reset();
    second_.reset();
    subs_.clear();
    requester_.reset();
    say_.reset();
    mic_.reset();
    camera_.reset();
  }

 private:
  // A "#rrggbb" colour of the config.
  static std::string colour(skr::plugin::Host& host, const char* key) {
    std::string c = host.configString(key);
    const bool ok = c.size() == 7 && c[0] == '#' &&
                    c.find_first_not_of("0123456789abcdefABCDEF", 1) == std::string::npos;
    if (!ok) {
      host.configError(key, "a colour \"#rrggbb\", not \"" + c + "\"");
      throw Failure(SKR_ERR_CONFIG, std::string("invalid ") + key);
    }
    return c;
  }

  static AvatarOptions readAvatar(skr::plugin::Host& host) {
    AvatarOptions o;
    o.blink_min_ms = host.configInt("blink_min_ms");
    o.blink_max_ms = host.configInt("blink_max_ms");
    o.blink_close_ms = host.configInt("blink_close_ms");
    o.blink_open_ms = host.configInt("blink_open_ms");
    o.min_motion = host.configDouble("min_motion");
    o.face_hold_ms = host.configInt("face_hold_ms");
    if (o.blink_max_ms < o.blink_min_ms) {
      host.configError("blink_max_ms", "need blink_min_ms <= blink_max_ms");
      throw Failure(SKR_ERR_CONFIG, "invalid blink_max_ms");
    }
    return o;
  }

  // Keys of the network page, which moved to the hub's web port (docs/observability.md).
  void warnRemovedKeys() {
    for (const char* key : {"network_token", "network_preview_hz"}) {
      if (host_.configHas(key)) {
        host_.log.warn("WSUI-CONFIG", key,
                       " is no longer used: the network page is served by the hub's web port "
                       "(server.web) and edits as its page account (docs/observability.md)");
      }
    }
  }

  void readServer() {
    WsServerOptions& o = server_opts_;
    if (!host_.configHas("port")) {
      // The hub's web port has its own address, files and TLS (server.web, server.tls).
      // (The declared defaults are filled in: "127.0.0.1" and "" mean untouched.)
      for (const char* key : {"address", "web_root", "tls_cert", "tls_key"}) {
        const std::string v = host_.configString(key);
        if (std::string(key) == "address" ? v != "127.0.0.1" : !v.empty()) {
          host_.configError(key,
                            "only with `port` (websocket-ui's own server); on the hub's "
                            "web port, server.web and server.tls say it");
          throw Failure(SKR_ERR_CONFIG, std::string("invalid ") + key);
        }
      }
    }
    o.address = host_.configString("address");
    o.port = static_cast<int>(host_.configInt("port"));
    o.web_root = host_.configString("web_root");
    if (o.web_root.empty()) o.web_root = defaultWebRoot();
    o.tls_cert = host_.configString("tls_cert");
    o.tls_key = host_.configString("tls_key");
    o.max_message_bytes = static_cast<std::size_t>(host_.configInt("max_message_bytes"));
    o.max_queued_bytes = static_cast<std::size_t>(host_.configInt("max_queued_bytes"));
  }

  void subscribe(const std::string& channel, skr::plugin::Subscription::DataFn fn) {
    if (channel.empty()) return;
    subs_.emplace_back(host_, channel, std::move(fn));
  }

  std::string welcome() const {
    Json::Value v(Json::objectValue);
    v["type"] = "welcome";
    v["version"] = 1;
    v["camera"]["width"] = camera_width_;
    v["camera"]["height"] = camera_height_;
    v["camera"]["fps"] = camera_fps_;
    v["camera"]["jpeg_quality"] = jpeg_quality_;
    v["mic_sample_rate"] = limits_.mic_sample_rate;
    v["avatar"]["light"] = light_colour_;
    v["avatar"]["eyes"] = eye_colour_;
    return writeJson(v);
  }

  // Server thread: check, then hand to the loop.
  std::optional<std::string> onBrowserMessage(std::uint64_t conn, bool binary, std::string&& data,
                                              int& code) {
    Inbound in = parseInbound(binary, data, limits_);
    if (auto* r = std::get_if<Refusal>(&in)) {
      code = r->close_code;
      return r->reason;
    }
    if (std::holds_alternative<Hello>(in)) return std::nullopt;
    if (auto* say = std::get_if<Say>(&in)) {
      host_.post([this, conn, s = *say] { sayFromBrowser(conn, s); });
      return std::nullopt;
    }
    const bool camera = std::holds_alternative<CameraFrame>(in);
    const skr::media::FrameHeader h =
        camera ? std::get<CameraFrame>(in).header : std::get<MicFrame>(in).header;
    host_.post([this, conn, camera, h, msg = std::move(data)]() mutable {
      camera ? publishCamera(conn, h, msg) : publishMic(conn, h, msg);
    });
    return std::nullopt;
  }

  // A message for every avatar page.
  void broadcast(bool binary, const std::string& msg, bool droppable = true) {
    for (auto conn : avatar_pages_) server_.send(conn, binary, msg, droppable);
  }

  // The channel's own frame numbers: browsers come and go, the channel's sequence goes on.
  void publishCamera(std::uint64_t conn, skr::media::FrameHeader h, std::string& msg) {
    if (!camera_owner_.accept(conn, nowMs())) return;
    h.seq = camera_seq_++;
    skr::media::writeHeader(h, msg.data());
    camera_.publish(msg);
    ++counters_.camera_frames;
  }

  // Sample counter of the channel; a gap in a browser's own counter becomes a gap here too.
  void publishMic(std::uint64_t conn, skr::media::FrameHeader h, std::string& msg) {
    if (!mic_owner_.accept(conn, nowMs())) return;
    const std::uint64_t samples = (msg.size() - skr::media::kHeaderBytes) / 2;
    auto it = mic_expected_.find(conn);
    if (it != mic_expected_.end() && h.seq > it->second) {
      mic_seq_ += h.seq - it->second;
      ++counters_.mic_gaps;
    }
    mic_expected_[conn] = h.seq + samples;
    h.seq = mic_seq_;
    mic_seq_ += samples;
    skr::media::writeHeader(h, msg.data());
    mic_.publish(msg);
    ++counters_.mic_frames;
  }

  void onFaces(std::string_view payload) {
    const auto parsed = channelObject(payload);
    if (!parsed) return;
    const Json::Value& v = *parsed;
    std::vector<Box> boxes;
    for (const auto& f : v["faces"]) {
      boxes.push_back(
          Box{f["x"].asDouble(), f["y"].asDouble(), f["w"].asDouble(), f["h"].asDouble()});
    }
    avatar_.onFaces(boxes, v["width"].asDouble(), v["height"].asDouble(), nowMs());
    sendWrapped("faces", payload);
  }

  void onMotion(std::string_view payload) {
    const auto parsed = channelObject(payload);
    if (!parsed) return;
    const Json::Value& v = *parsed;
    std::optional<std::pair<double, double>> centre;
    if (v["center"].isObject()) centre = {v["center"]["x"].asDouble(), v["center"]["y"].asDouble()};
    avatar_.onMotion(v["amount"].asDouble(), centre, v["width"].asDouble(), v["height"].asDouble(),
                     nowMs());
    sendWrapped("motion", payload);
  }

  void onCodes(std::string_view payload) {
    const auto parsed = channelObject(payload);
    if (!parsed) return;
    const Json::Value& v = *parsed;
    avatar_.onCodes(v["codes"].isArray() && !v["codes"].empty(), nowMs());
    sendWrapped("codes", payload);
  }

  void forward(const char* type, std::string_view payload) {
    if (channelObject(payload)) sendWrapped(type, payload);
  }

  // A channel's JSON message (parsed already, so valid) to the browsers as {"type", "data"},
  // without writing it out again.
  void sendWrapped(const char* type, std::string_view json) {
    if (avatar_pages_.empty()) return;
    std::string msg;
    msg.reserve(json.size() + 32);
    msg.append(R"({"type":)").append(skr::support::jsonQuote(type)).append(R"(,"data":)");
    msg.append(json).append("}");
    broadcast(false, msg);
  }

  // The phoneme timeline of an utterance becomes a viseme timeline, sent before its audio.
  void onPhonemes(std::string_view payload) {
    const auto parsed = channelObject(payload);
    if (!parsed) return;
    const Json::Value& v = *parsed;
    std::vector<TimedPhoneme> phonemes;
    for (const auto& p : v["phonemes"])
      phonemes.push_back({p["ph"].asString(), p["start_ms"].asDouble()});
    const double duration = v["duration_ms"].asDouble();
    Json::Value msg(Json::objectValue);
    msg["type"] = "speech";
    msg["utterance"] = v["utterance"];
    msg["start_seq"] = v["start_seq"];
    msg["sample_rate"] = v["sample_rate"];
    msg["duration_ms"] = duration;
    msg["text"] = v["text"];
    Json::Value& list = msg["visemes"] = Json::Value(Json::arrayValue);
    for (const auto& tv : visemeTimeline(phonemes, duration)) {
      Json::Value e(Json::objectValue);
      e["t_ms"] = tv.t_ms;
      e["v"] = tv.viseme.name;
      e["open"] = tv.viseme.open;
      e["wide"] = tv.viseme.wide;
      e["round"] = tv.viseme.round;
      list.append(e);
    }
    broadcast(false, writeJson(msg), false);
  }

  // {"error": why}; `why` is a message, or JSON text (a string) from the Requester.
  static std::string errorJson(Json::Value why) {
    Json::Value v(Json::objectValue);
    v["error"] = std::move(why);
    return writeJson(v);
  }
  // JSON text from the hub (a service's answer, or the Requester's reason) as a value.
  static Json::Value answerValue(const std::string& json) {
    auto v = skr::support::parseJson(json, kChannelLimits);
    return v ? std::move(*v) : Json::Value(json);
  }

  // Forwards the request to the speech service; its answer, or {"error"}, goes back.
  void onSayRequest(const skr::plugin::ServiceRequest& r) {
    if (r.command == "expression") return onExpressionRequest(r);
    ++counters_.say_requests;
    const std::uint64_t id = r.id;
    if (speech_.empty()) {
      say_.respond(id, errorJson("no speech service is configured (config key \"speech\")"));
      return;
    }
    const bool sent = requester_->request(
        speech_, "say", r.value_json, [this, id](bool ok, const std::string& value) {
          say_.respond(id, ok ? value : errorJson(answerValue(value)));
        });
    if (!sent) say_.respond(id, errorJson("the speech service " + speech_ + " is not running"));
  }

  // An expression for every page: {"name", "weight" (1), "duration_ms" (2000)}.
  void onExpressionRequest(const skr::plugin::ServiceRequest& r) {
    const auto v = skr::support::parseJson(r.value_json, kChannelLimits);
    if (!v || !v->isObject() || !(*v)["name"].isString()) {
      say_.respond(r.id, errorJson("expression takes {\"name\", \"weight\", \"duration_ms\"}"));
      return;
    }
    Json::Value msg(Json::objectValue);
    msg["type"] = "expression";
    msg["name"] = (*v)["name"];
    msg["weight"] = std::clamp(v->get("weight", 1.0).asDouble(), 0.0, 1.0);
    msg["duration_ms"] = std::clamp<Json::Int64>(v->get("duration_ms", 2000).asInt64(), 0, 60000);
    broadcast(false, writeJson(msg));
    say_.respond(r.id, writeJson(msg));
  }

  void sayFromBrowser(std::uint64_t conn, const Say& s) {
    ++counters_.say_requests;
    auto said = [this, conn](bool ok, Json::Value result) {
      Json::Value msg(Json::objectValue);
      msg["type"] = "said";
      msg["ok"] = ok;
      msg["result"] = std::move(result);
      server_.send(conn, false, writeJson(msg));
    };
    if (speech_.empty()) {
      said(false, "no speech service is configured");
      return;
    }
    Json::Value value(Json::objectValue);
    value["text"] = s.text;
    if (!s.voice.empty()) value["voice"] = s.voice;
    const bool sent =
        requester_->request(speech_, "say", writeJson(value),
                            [said](bool ok, const std::string& v) { said(ok, answerValue(v)); });
    if (!sent) said(false, "the speech service " + speech_ + " is not running");
  }

  void behave() {
    const std::int64_t now = nowMs();
    if (auto g = avatar_.gazeDue(now)) {
      Json::Value msg(Json::objectValue);
      msg["type"] = "gaze";
      msg["x"] = g->x;
      msg["y"] = g->y;
      msg["source"] = g->source;
      broadcast(false, writeJson(msg));
    }
    if (auto e = avatar_.expressionDue()) {
      Json::Value msg(Json::objectValue);
      msg["type"] = "expression";
      msg["name"] = e->name;
      msg["weight"] = e->weight;
      msg["duration_ms"] = static_cast<Json::Int64>(e->duration_ms);
      broadcast(false, writeJson(msg));
    }
    if (auto b = avatar_.blinkDue(now)) {
      Json::Value msg(Json::objectValue);
      msg["type"] = "blink";
      msg["close_ms"] = static_cast<Json::Int64>(b->close_ms);
      msg["hold_ms"] = static_cast<Json::Int64>(b->hold_ms);
      msg["open_ms"] = static_cast<Json::Int64>(b->open_ms);
      broadcast(false, writeJson(msg));
    }
  }

  void report() {
    const WsServerStats s = server_.stats();
    const std::string db(host_.name());
    using skr::plugin::dbSet;
    dbSet(host_, db, "browsers", std::to_string(s.connections));
    dbSet(host_, db, "browsers_accepted", std::to_string(s.accepted));
    dbSet(host_, db, "refused", std::to_string(s.refused));
    dbSet(host_, db, "refused_handshakes", std::to_string(s.refused_handshakes));
    dbSet(host_, db, "dropped", std::to_string(s.dropped));
    dbSet(host_, db, "camera_frames", std::to_string(counters_.camera_frames));
    dbSet(host_, db, "mic_frames", std::to_string(counters_.mic_frames));
    dbSet(host_, db, "mic_gaps", std::to_string(counters_.mic_gaps));
    dbSet(host_, db, "camera_ignored", std::to_string(camera_owner_.ignored()));
    dbSet(host_, db, "mic_ignored", std::to_string(mic_owner_.ignored()));
    dbSet(host_, db, "say_requests", std::to_string(counters_.say_requests));
    dbSet(host_, db, "gaze_source", skr::support::jsonQuote(avatar_.lastGaze().source));
    if (!server_.onHub()) dbSet(host_, db, "port", std::to_string(server_.port()));
  }

  std::int64_t nowMs() const { return host_.nowNs() / 1000000; }

  skr::plugin::Host& host_;
  WsServerOptions server_opts_;
  InboundLimits limits_;
  int camera_width_ = 640, camera_height_ = 360, camera_fps_ = 15;
  double jpeg_quality_ = 0.7;
  std::string light_colour_;  // "#rrggbb", for the page (welcome)
  std::string eye_colour_;
  std::string faces_, motion_, codes_, bands_, speech_, voice_, phonemes_, dialogue_;

  AvatarBehaviour avatar_;
  SourceOwner camera_owner_, mic_owner_;  // loop thread
  Browsers server_;
  skr::plugin::StreamChannel camera_, mic_;
  skr::plugin::ServiceChannel say_;
  std::optional<skr::plugin::Requester> requester_;
  std::vector<skr::plugin::Subscription> subs_;
  skr::plugin::TickHandle fast_, second_;

  // Loop thread only.
  std::uint64_t camera_seq_ = 0;
  std::uint64_t mic_seq_ = 0;
  std::map<std::uint64_t, std::uint64_t> mic_expected_;  // browser -> its next sample index
  std::set<std::uint64_t> avatar_pages_;                 // open
  Counters counters_;
};

}  // namespace
}  // namespace skr::wsui

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    // The server.
    // Absent `port`: the hub's web port (server.web) serves the page and /ws. With a `port`, the
    // module's own server, and the four keys below it.
    cfg::integer("port", nullptr,
                 "its own HTTP and WebSocket server's port (0: any free port); absent: the "
                 "hub's web port")
        .range(0, 65535),
    cfg::string("address", "127.0.0.1", "its own server's interface; \"0.0.0.0\" for every one")
        .nonEmpty(),
    cfg::string("web_root", "",
                "its own server's directory; empty: the page installed with the hub "
                "(share/skrobot/web) or a build tree's copy"),
    cfg::string("tls_cert", "", "its own server's PEM certificate; with tls_key: HTTPS and WSS"),
    cfg::string("tls_key", "", "PEM private key of tls_cert"),
    cfg::integer("max_message_bytes", "1048576", "largest browser message")
        .range(64 * 1024, 64 * 1024 * 1024),
    cfg::integer("max_queued_bytes", "8388608",
                 "per-browser output queue; beyond it the oldest "
                 "droppable messages go")
        .min(0),
    // What the page sends.
    cfg::integer("camera_width", "640", "camera frame width asked of the page").range(16, 1920),
    cfg::integer("camera_height", "360", "camera frame height asked of the page").range(16, 1080),
    cfg::integer("camera_fps", "15", "camera frames per second asked of the page").range(1, 60),
    cfg::number("jpeg_quality", "0.7", "JPEG quality of the page's camera frames").range(0, 1),
    cfg::integer("mic_sample_rate", "22050", "the page resamples the microphone to this rate")
        .range(8000, 48000),
    cfg::integer("handover_ms", "1000", "quiet time before another page may feed camera or mic")
        .min(0),
    // Other modules' channels ("": none).
    cfg::string("faces", "", "face detections shown and looked at, e.g. face-detect.faces"),
    cfg::string("motion", "", "motion results looked at, e.g. motion.motion"),
    cfg::string("codes", "", "QR/barcode results shown, e.g. qrcode.codes"),
    cfg::string("bands", "", "audio band levels shown, e.g. fft-audio.bands"),
    cfg::string("speech", "", "the speech service that say goes to, e.g. speech.say"),
    cfg::string("voice", "", "speech audio played in the page, e.g. speech.voice"),
    cfg::string("phonemes", "", "speech timelines that move the lips, e.g. speech.phonemes"),
    cfg::string("dialogue", "", "what the agent heard and answered, shown, e.g. agent.dialogue"),
    // Removed: the network page is on the hub's web port (a config naming them is warned).
    cfg::any("network_token", nullptr, "removed (the network page edits as server.web's account)"),
    cfg::any("network_preview_hz", nullptr, "removed (the network page previews at 5 Hz)"),
    // The avatar's behaviour.
    cfg::integer("blink_min_ms", "450", "shortest interval between blinks").min(100),
    cfg::integer("blink_max_ms", "4000", "longest interval between blinks (>= blink_min_ms)")
        .min(100),
    cfg::integer("blink_close_ms", "70", "time the eyelids take to close").min(1),
    cfg::integer("blink_open_ms", "160", "time the eyelids take to open").min(1),
    cfg::number("min_motion", "0.004", "fraction of moving pixels that draws the gaze").range(0, 1),
    cfg::integer("face_hold_ms", "1000", "how long a face keeps the gaze after it was last seen")
        .min(0),
    // The character's colours (docs/websocket-ui.md, "The character").
    cfg::string("avatar_light", "#7fe6ff",
                "the robot's light: brows, mouth, ears and antenna, \"#rrggbb\""),
    cfg::string("avatar_eyes", "#38c2e8", "the robot's irises, \"#rrggbb\""),
};

SKR_MODULE_WITH_CONFIG(
    skr::wsui::WebsocketUi, "websocket-ui", "1.0.0",
    "serves the avatar page; browsers' camera and microphone to channels, avatar behaviour", 0,
    kConfig)
