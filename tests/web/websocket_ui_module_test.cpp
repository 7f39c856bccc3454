// SPDX-License-Identifier: Apache-2.0
// websocket-ui in a hub, without a browser: its say service goes to the speech service that the
// config names (none by default), and a channel name with a quote in it still gives a valid
// JSON answer that carries the name.
#include "module_fixture.h"

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace skr::test {
namespace {

using flow::Code;
using flow::Variant;
namespace msg = flow::msg;

constexpr std::uint32_t kCallMs = 10000;

class WebsocketUiModule : public ModuleFixture {
 protected:
  // Starts the hub and websocket-ui as "ui" on a free port, with more config members `extra`.
  void start(const std::string& extra = "") {
    startHub();
    ASSERT_TRUE(startModule("ui", R"({"port":0)" + extra + "}", false, "websocket-ui").empty());
    sync_.emplace(syncClient());
    auto info = as<msg::ChannelInfoReply>(sync_->call(msg::ChanInfoByName{"ui.say"}));
    ASSERT_TRUE(info);
    say_ = info->info.id;
  }
  // A blocking call of ui.say; the answer as JSON (null when no answer came).
  Json::Value say(const std::string& value_json) {
    auto value = flow::variantFromJsonText(value_json);
    EXPECT_TRUE(value) << value_json;
    if (!value) return {};
    auto reply =
        as<msg::ReplyValue>(sync_->call(msg::ServiceCall{say_, kCallMs, "say", value.value()}));
    EXPECT_TRUE(reply) << "no answer from ui.say";
    return reply ? reply->value.toJson() : Json::Value();
  }

  std::optional<TestClient> sync_;
  std::uint16_t say_ = 0;
};

TEST_F(WebsocketUiModule, NoSpeechServiceUnlessConfigured) {
  start();
  const Json::Value answer = say(R"({"text":"hello"})");
  ASSERT_TRUE(answer["error"].isString()) << answer.toStyledString();
  EXPECT_NE(answer["error"].asString().find("no speech service"), std::string::npos)
      << answer["error"].asString();
}

TEST_F(WebsocketUiModule, ForwardsToTheConfiguredSpeechService) {
  start(R"(,"speech":"guest.talk")");
  TestClient owner = flowClient();
  const std::uint16_t talk = addChannel(owner, "talk", flow::ChannelKind::service);
  std::optional<msg::EvServiceRequest> seen;
  std::thread answer([&] {
    seen = as<msg::EvServiceRequest>(owner.waitFor(Code::ev_service_request, kCallMs));
    if (seen) {
      auto v = flow::variantFromJsonText(R"({"utterance":7,"duration_ms":500})");
      (void)owner.send(msg::ServiceResponse{talk, seen->request, v.value()});
    }
  });
  const Json::Value got = say(R"({"text":"ciao","voice":"it"})");
  answer.join();
  ASSERT_TRUE(seen) << "guest.talk got no request";
  EXPECT_EQ(seen->command, "say");
  EXPECT_EQ(seen->value.toJson()["text"].asString(), "ciao");
  EXPECT_EQ(seen->value.toJson()["voice"].asString(), "it");
  EXPECT_EQ(got["utterance"].asInt(), 7) << got.toStyledString();
}

// Before the module-support library the answer was built by concatenation: the quote ended the
// JSON string early, the hub refused the broken answer and the caller got none.
TEST_F(WebsocketUiModule, AQuoteInTheSpeechChannelNameRoundTrips) {
  const std::string name = R"(no"such\.say)";
  start(R"(,"speech":"no\"such\\.say")");
  const Json::Value answer = say(R"({"text":"hello"})");
  ASSERT_TRUE(answer["error"].isString()) << answer.toStyledString();
  EXPECT_NE(answer["error"].asString().find(name), std::string::npos) << answer["error"].asString();
}

// The declared config keys: the host refuses out-of-range values and unknown keys, naming them;
// the blink interval's order and the colours are the module's own checks.
TEST_F(WebsocketUiModule, BadConfigFailsNamingTheKey) {
  startHub();
  int n = 0;
  auto failure = [&](const std::string& config) {
    const auto f = startModule("ui" + std::to_string(n++), config, false, "websocket-ui");
    EXPECT_EQ(f.size(), 1u) << config;
    return f.empty() ? std::string() : f[0];
  };
  for (const auto& [config, key] : std::vector<std::pair<std::string, std::string>>{
           {R"({"port":70000})", "port"},
           {R"({"port":0,"spech":"speech.say"})", "spech"},
           {R"({"port":0,"camera_fps":0})", "camera_fps"},
           {R"({"port":0,"faces":7})", "faces"}}) {
    const std::string f = failure(config);
    EXPECT_NE(f.find("config." + key), std::string::npos) << config << ": " << f;
  }
  const std::string f = failure(R"({"port":0,"blink_min_ms":500,"blink_max_ms":400})");
  EXPECT_NE(f.find("invalid blink_max_ms"), std::string::npos) << f;
  // A colour that is not "#rrggbb".
  for (const char* colour : {"blue", "#12345", "#12345g"}) {
    const std::string c = failure(std::string(R"({"port":0,"avatar_light":")") + colour + "\"}");
    EXPECT_NE(c.find("invalid avatar_light"), std::string::npos) << colour << ": " << c;
  }
}

// Without a `port` the module is an endpoint of the hub's web port: with none, it fails naming
// server.web; its own server's keys without a `port` are refused, naming the key.
TEST_F(WebsocketUiModule, OnTheWebPortOrItsOwn) {
  startHub();  // no server.web
  const auto none = startModule("ui", "{}", false, "websocket-ui");
  ASSERT_EQ(none.size(), 1u);
  EXPECT_NE(none[0].find("server.web"), std::string::npos) << none[0];
  const auto tls = startModule("ui2", R"({"tls_cert":"/etc/x.pem"})", false, "websocket-ui");
  ASSERT_EQ(tls.size(), 1u);
  EXPECT_NE(tls[0].find("invalid tls_cert"), std::string::npos) << tls[0];
}

// The network page's keys went with it to the hub's web port: a config that still names them
// loads (websocket-ui warns, WSUI-CONFIG).
TEST_F(WebsocketUiModule, RemovedNetworkKeysStillLoad) {
  startHub();
  EXPECT_TRUE(startModule("ui", R"({"port":0,"network_token":"x","network_preview_hz":5})", false,
                          "websocket-ui")
                  .empty());
}

}  // namespace
}  // namespace skr::test
