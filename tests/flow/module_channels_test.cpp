// SPDX-License-Identifier: Apache-2.0
// Modules on the FlowNetwork: the ABI 1.1 calls from a C module, and in-process zero-copy.
#include "eventually.h"
#include "flow_fixture.h"
#include "log_capture.h"

#include <skrobot/hub/module_host.h>
#include <skrobot/plugin.h>

#include <algorithm>

namespace skr::test {
namespace {

using flow::Code;
using flow::Variant;
namespace msg = flow::msg;

class ModuleChannels : public FlowFixture {
 protected:
  void startModules(const std::string& module = "test_channel_echo",
                    const Json::Value& config = Json::Value(Json::objectValue),
                    bool own_thread = false) {
    onHub([&] {
      host_ = std::make_unique<ModuleHost>(hub_->loop(), std::vector<std::filesystem::path>{},
                                           server_.get());
      ModuleEntry e;
      e.name = module;
      e.path = std::filesystem::path(SKROBOT_TEST_MODULE_DIR) / (module + ".so");
      e.config = config;
      e.own_thread = own_thread;
      host_->start({e});
      EXPECT_EQ(host_->failures().size(), 0u);
      EXPECT_EQ(host_->modules().size(), 1u);
    });
  }
  void TearDown() override {
    if (hub_) onHub([&] { host_.reset(); });
    FlowFixture::TearDown();
  }
  void checkBlobModule(const std::string& module, const std::string& bad);
  void checkEchoModule(bool own_thread);
  std::unique_ptr<ModuleHost> host_;
};

// test_channel_echo: its channels, a subscription made before its channel exists, a service,
// its database, a channel watch; on the main loop or on its own thread (ABI 1.10), where every
// callback must come on that thread.
void ModuleChannels::checkEchoModule(bool own_thread) {
  LogCapture logs;
  startHub();
  startModules("test_channel_echo", Json::Value(Json::objectValue), own_thread);
  EXPECT_TRUE(logs.sawLine(std::string("ECHO-THREAD ") + (own_thread ? "own" : "main")));
  TestClient sat = flowClient();
  // The module's channels exist, with their properties.
  TestClient sync = syncClient();
  auto info = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_channel_echo.out"}));
  ASSERT_TRUE(info);
  EXPECT_EQ(*info->info.props.find("note"), Variant("echo of guest.in"));
  EXPECT_EQ(info->info.owner, "test_channel_echo");
  auto svc = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_channel_echo.svc"}));
  ASSERT_TRUE(svc);

  // Subscribing to the module's output tells the module (first subscriber).
  ASSERT_TRUE(sat.send(msg::Subscribe{1, info->info.id}));
  // guest.in appears: the module's waiting subscription attaches, so the satellite hears that
  // its channel has a subscriber.
  const uint16_t in = addChannel(sat, "in");
  ASSERT_TRUE(sat.waitFor(Code::ev_start_publish));
  ASSERT_TRUE(sat.send(msg::Publish{in, msg::Rest{"hello module"}}));
  auto echoed = as<msg::EvData>(sat.waitFor(Code::ev_data));
  ASSERT_TRUE(echoed);
  EXPECT_EQ(echoed->chan_id, info->info.id);
  EXPECT_EQ(echoed->payload.bytes, "hello module");

  // Its service answers.
  ASSERT_TRUE(sat.send(msg::ServiceRequest{5, svc->info.id, "shout", Variant("hi")}));
  auto resp = as<msg::EvServiceResponse>(sat.waitFor(Code::ev_service_response));
  ASSERT_TRUE(resp);
  EXPECT_EQ(resp->error, 0);
  EXPECT_EQ(*resp->value.find("echo"), Variant("hi"));
  EXPECT_EQ(*resp->value.find("cmd"), Variant("shout"));

  // Its database, written through db_set.
  ASSERT_EQ(sync.call(msg::DbSelect{"test_channel_echo"})->kind(), Code::reply_ok);
  auto count = as<msg::ReplyValue>(sync.call(msg::VarGet{"echoed"}));
  ASSERT_TRUE(count);
  EXPECT_EQ(count->value, Variant(int64_t{1}));

  // Its channel watch saw a channel added.
  EXPECT_NE(addChannel(sat, "late"), 0);
  EXPECT_TRUE(eventually([&] { return logs.sawLine("ECHO-SEEN guest.late"); })) << "the watch";

  // Stopping the module removes its channels, and everyone is told.
  onHub([&] { host_->shutdown(); });
  bool out_gone = false;
  for (int i = 0; i < 2; ++i) {
    auto removed = as<msg::EvChanRemoved>(sat.waitFor(Code::ev_chan_removed));
    ASSERT_TRUE(removed);
    out_gone = out_gone || removed->name == "test_channel_echo.out";
  }
  EXPECT_TRUE(out_gone);
  EXPECT_FALSE(logs.sawTag("ECHO-WRONG-THREAD"));
}

TEST_F(ModuleChannels, CModuleCreatesPublishesSubscribesAndAnswers) {
  checkEchoModule(false);
}

TEST_F(ModuleChannels, AModuleOnItsOwnThreadUsesChannelsFromThatThread) {
  checkEchoModule(true);
}

// A module on its own thread that falls behind loses messages, not the hub's memory: while its
// thread sleeps, 100 MiB arrive for it; at most ModuleFlow::kMaxBehindBytes (64 MiB) wait.
TEST_F(ModuleChannels, AModuleOnItsOwnThreadThatFallsBehindLosesMessagesNotMemory) {
  LogCapture logs;
  startHub();
  startModules("test_channel_echo", Json::Value(Json::objectValue), true);
  TestClient sat = flowClient();
  TestClient sync = syncClient();
  auto out = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_channel_echo.out"}));
  auto svc = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_channel_echo.svc"}));
  ASSERT_TRUE(out && svc);
  ASSERT_TRUE(sat.send(msg::Subscribe{1, out->info.id}));
  const uint16_t in = addChannel(sat, "in");
  ASSERT_TRUE(sat.waitFor(Code::ev_start_publish));
  ASSERT_TRUE(sat.send(msg::ServiceRequest{7, svc->info.id, "sleep", Variant(int64_t{3000})}));
  const std::string mib(1u << 20, 'x');
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(sat.send(msg::Publish{in, msg::Rest{mib}}));
  ASSERT_TRUE(sat.waitFor(Code::ev_service_response, 20000));
  EXPECT_TRUE(eventually([&] { return logs.sawTag("MODULE-BEHIND"); }));
  // What waited is echoed, then the count stays.
  ASSERT_EQ(sync.call(msg::DbSelect{"test_channel_echo"})->kind(), Code::reply_ok);
  const auto echoed = [&] {
    auto v = as<msg::ReplyValue>(sync.call(msg::VarGet{"echoed"}));
    return v ? v->value.asInt64().value_or(0) : int64_t{0};
  };
  int64_t last = -1;
  ASSERT_TRUE(eventually(
      [&] {
        const int64_t now = echoed();
        const bool settled = now == last && now > 0;
        last = now;
        return settled;
      },
      20000));
  EXPECT_LE(last, 64 + 1);  // ModuleFlow::kMaxBehindBytes, 64 MiB
  EXPECT_GT(last, 0);
  // The drops are counted as a slow subscriber's are, on guest.in (hub.stats).
  uint64_t dropped = 0;
  onHub([&] {
    for (const auto& c : server_->snapshot().channels) {
      if (c.name == "guest.in") dropped = c.dropped;
    }
  });
  EXPECT_GE(dropped, uint64_t(100 - 65));
  EXPECT_FALSE(logs.sawTag("ECHO-WRONG-THREAD"));
}

TEST_F(ModuleChannels, BlockingCallsAnsweredAtOnceByAModuleKeepTheConnectionUsable) {
  startHub();
  startModules();
  TestClient sync = syncClient();
  auto svc = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_channel_echo.svc"}));
  ASSERT_TRUE(svc);
  // The module answers inside the request: the reply must still come, each time.
  for (int i = 0; i < 3; ++i) {
    auto v = as<msg::ReplyValue>(
        sync.call(msg::ServiceCall{svc->info.id, 5000, "n", Variant(int64_t{i})}));
    ASSERT_TRUE(v) << "call " << i;
    EXPECT_EQ(*v->value.find("echo"), Variant(int64_t{i}));
  }
  EXPECT_EQ(sync.call(msg::Ping{msg::Rest{"still"}})->kind(), Code::reply_ok);
}

TEST_F(ModuleChannels, InProcessSubscribersGetThePublishersBufferWithoutCopy) {
  startHub();
  onHub([&] {
    const void* seen = nullptr;
    size_t calls = 0;
    flow::LocalHandlers sub_handlers;
    sub_handlers.on_data = [&](uint16_t, std::string_view payload) {
      seen = payload.data();
      ++calls;
    };
    auto publisher = server_->attachLocal("camera", "camera", {});
    auto subscriber = server_->attachLocal("vision", "vision", std::move(sub_handlers));
    ASSERT_TRUE(subscriber->subscribe("camera.frames"));  // before the channel exists
    auto id = publisher->createChannel("frames", flow::ChannelKind::streaming, "image/jpeg",
                                       Variant(Variant::Map{}));
    ASSERT_TRUE(id);
    const std::string frame(640 * 360, 'j');
    ASSERT_TRUE(publisher->publish(*id, frame));
    EXPECT_EQ(calls, 1u);
    EXPECT_EQ(seen, frame.data());  // the very same bytes: no copy
    // Re-created channel: the subscription follows it.
    ASSERT_TRUE(publisher->removeChannel(*id));
    auto again = publisher->createChannel("frames", flow::ChannelKind::streaming, "", Variant());
    ASSERT_TRUE(again);
    ASSERT_TRUE(publisher->publish(*again, "x"));
    EXPECT_EQ(calls, 2u);
    // Only the owner publishes.
    EXPECT_FALSE(subscriber->publish(*again, "spoof"));
  });
}

// The hub's state belongs to its loop thread: in the debug and AddressSanitizer builds, an
// in-process client's call from another thread aborts, naming the call.
TEST_F(ModuleChannels, HubStateTouchedOffItsLoopAbortsInDebugBuilds) {
#ifdef NDEBUG
  GTEST_SKIP() << "debug assertions: the debug and AddressSanitizer builds";
#else
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  startHub();
  std::unique_ptr<flow::LocalClient> client;
  onHub([&] { client = server_->attachLocal("guest", "probe", {}); });
  EXPECT_DEATH((void)client->publish(1, "x"), "LocalClient::publish called off loop");
  onHub([&] { client.reset(); });
#endif
}

// The calls whose callbacks cannot come on a module's own thread yet (the blob calls among them)
// are refused there; its channel calls work.
TEST_F(ModuleChannels, ModulesOnTheirOwnThreadAreToldBlobCallsAreMainLoopOnly) {
  startHub();
  startModules("test_blob_files", Json::Value(Json::objectValue), true);
  TestClient sat = flowClient();
  TestClient sync = syncClient();
  auto report = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_blob_files.report"}));
  ASSERT_TRUE(report);
  ASSERT_TRUE(sat.send(msg::Subscribe{1, report->info.id}));  // the module starts its calls
  auto first = as<msg::EvData>(sat.waitFor(Code::ev_data));
  ASSERT_TRUE(first);
  EXPECT_EQ(first->payload.bytes, "bad:" + std::to_string(SKR_ERR_NOT_ON_LOOP_THREAD));
  EXPECT_FALSE(sat.waitFor(Code::ev_data, 300));  // its blob_put was refused too: no answer
}

// A module that reads and writes its blob channel (test_blob_files in C, test_blob_files_cpp
// through plugin_blobs.hpp): the lines it reports, then the channel as satellites see it.
// `bad`: its first line, about a path refused at once.
void ModuleChannels::checkBlobModule(const std::string& module, const std::string& bad) {
  startHub();
  startModules(module);
  TestClient sat = flowClient();
  TestClient sync = syncClient();
  auto report = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{module + ".report"}));
  ASSERT_TRUE(report);
  ASSERT_TRUE(sat.send(msg::Subscribe{1, report->info.id}));  // the module starts its calls
  std::vector<std::string> lines;
  while (lines.size() < 8) {
    auto d = as<msg::EvData>(sat.waitFor(Code::ev_data));
    ASSERT_TRUE(d) << "after " << lines.size() << " lines";
    lines.emplace_back(d->payload.bytes);
  }
  const auto has = [&](const std::string& prefix) {
    return std::any_of(lines.begin(), lines.end(),
                       [&](const std::string& l) { return l.rfind(prefix, 0) == 0; });
  };
  EXPECT_EQ(lines[0], bad);  // refused at once
  EXPECT_TRUE(has("put:0:versioned"));
  EXPECT_TRUE(has("get:0:hello from a module"));
  EXPECT_TRUE(has("list:0:[{\"dir\":false,\"mtime_ns\":"));
  EXPECT_TRUE(has("removed:0"));
  EXPECT_TRUE(has("missing:" + std::to_string(SKR_ERR_NOT_FOUND) + ":no such file"));
  EXPECT_TRUE(has("event:0:{\"change\":\"written\",\"path\":\"a/hello.txt\",\"size\":19,"));
  EXPECT_TRUE(has("event:0:{\"change\":\"removed\",\"path\":\"a/hello.txt\""));
  EXPECT_FALSE(has("never:"));
  // A satellite reads the module's files, and the channel outlives the module.
  auto files = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{module + ".files"}));
  ASSERT_TRUE(files);
  EXPECT_EQ(files->info.kind, uint8_t(flow::ChannelKind::blob));
  onHub([&] { host_.reset(); });
  auto kept = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{module + ".files"}));
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->info.owner_connection, 0u);
  // A satellite may not write to it.
  auto denied = as<msg::ReplyError>(sync.call(msg::BlobMkdir{kept->info.id, "x"}));
  ASSERT_TRUE(denied);
  EXPECT_EQ(denied->error, uint16_t(flow::ErrorCode::permission_denied));
}

TEST_F(ModuleChannels, CModuleReadsAndWritesItsBlobChannel) {
  checkBlobModule("test_blob_files", "bad:" + std::to_string(SKR_ERR_INVALID_ARGUMENT));
}

TEST_F(ModuleChannels, CppModuleReadsAndWritesItsBlobChannel) {
  checkBlobModule("test_blob_files_cpp", "bad:refused");
}

// --- the sync pulse (ABI 1.5): test_sync_step follows guest.clock, pulses its own "beat" -----

class ModuleSync : public ModuleChannels {
 protected:
  // Starts the module and a satellite subscribed to its "ticks" (one line per pulse it got).
  void start(const Json::Value& config = Json::Value(Json::objectValue)) {
    startHub();
    startModules("test_sync_step", config);
    sat_ = flowClient();
    TestClient sync = syncClient();
    auto ticks = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_sync_step.ticks"}));
    ASSERT_TRUE(ticks);
    ASSERT_TRUE(sat_.send(msg::Subscribe{1, ticks->info.id}));
    ASSERT_TRUE(sat_.send(msg::DbSetCurrent{2, "guest"}));  // a round trip: subscribed now
    ASSERT_TRUE(sat_.waitFor(Code::ev_db_changed));
  }
  // The module's next line on "ticks", or "" when none comes.
  std::string nextTick(int timeout_ms = 5000) {
    auto d = as<msg::EvData>(sat_.waitFor(Code::ev_data, timeout_ms));
    return d ? std::string(d->payload.bytes) : std::string();
  }
  void pulse(uint16_t source) { ASSERT_TRUE(sat_.send(msg::SyncPulse{source, 0})); }
  TestClient sat_;
};

TEST_F(ModuleSync, AModuleFollowsASourceMadeAfterItAndIsASourceItself) {
  start();
  // guest.clock appears after the module asked to follow it: the follow attaches.
  const uint16_t clock = addChannel(sat_, "clock", flow::ChannelKind::sync);
  ASSERT_NE(clock, 0);
  for (int i = 1; i <= 3; ++i) {
    pulse(clock);
    EXPECT_EQ(nextTick(), std::to_string(i) + ":0");  // each finished when its handler returned
  }
  // The module's own source: a satellite follows it; each message on guest.trigger pulses it.
  TestClient sync = syncClient();
  auto beat = as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_sync_step.beat"}));
  ASSERT_TRUE(beat);
  EXPECT_EQ(beat->info.kind, static_cast<uint8_t>(flow::ChannelKind::sync));
  TestClient target = flowClient();
  ASSERT_TRUE(target.send(msg::SyncFollow{3, beat->info.id, 1}));
  ASSERT_TRUE(target.send(msg::DbSetCurrent{4, "guest"}));  // a round trip: it follows now
  ASSERT_TRUE(target.waitFor(Code::ev_db_changed));
  const uint16_t trigger = addChannel(sat_, "trigger");
  ASSERT_TRUE(sat_.waitFor(Code::ev_start_publish));  // the module subscribes to it
  ASSERT_TRUE(sat_.send(msg::Publish{trigger, msg::Rest{"go"}}));
  auto p = as<msg::EvSyncPulse>(target.waitFor(Code::ev_sync_pulse));
  ASSERT_TRUE(p);
  EXPECT_EQ(p->chan_id, beat->info.id);
  EXPECT_EQ(p->seq, 1u);
  // Re-created, the source is followed again; unfollowed, its pulses stop reaching the module.
  ASSERT_TRUE(sat_.send(msg::ChanRemove{4, clock}));
  const uint16_t again =
      addChannel(sat_, "clock", flow::ChannelKind::sync, Variant(Variant::Map{}), 78);
  pulse(again);
  EXPECT_EQ(nextTick(), "1:0");
  ASSERT_TRUE(sat_.send(msg::Publish{trigger, msg::Rest{"unfollow"}}));
  pulse(again);
  EXPECT_EQ(nextTick(300), "");
}

TEST_F(ModuleSync, AModuleThatFinishesLaterLosesThePulsesThatComeMeanwhile) {
  Json::Value config(Json::objectValue);
  config["later"] = true;
  config["every"] = 2;
  start(config);
  const uint16_t clock = addChannel(sat_, "clock", flow::ChannelKind::sync);
  const uint16_t finish = addChannel(sat_, "finish");
  ASSERT_TRUE(sat_.waitFor(Code::ev_start_publish));
  pulse(clock);
  pulse(clock);
  EXPECT_EQ(nextTick(), "2:0");              // every 2nd
  for (int i = 0; i < 4; ++i) pulse(clock);  // 4 and 6 are due while 2 is not finished
  EXPECT_EQ(nextTick(300), "");
  ASSERT_TRUE(sat_.send(msg::Publish{finish, msg::Rest{"."}}));  // sync_done(2)
  pulse(clock);
  pulse(clock);
  EXPECT_EQ(nextTick(), "8:2");
}

// --- watching (ABI 1.6): test_watch_calls reports guest's channels and database "shared" ------

TEST_F(ModuleChannels, AModuleWatchesChannelsAndADatabaseFromWhatThereIsNow) {
  startHub();
  TestClient sat = flowClient();
  TestClient sync = syncClient();
  ASSERT_EQ(sync.call(msg::DbCreate{"shared"})->kind(), Code::reply_ok);
  ASSERT_EQ(sync.call(msg::DbSelect{"shared"})->kind(), Code::reply_ok);
  ASSERT_EQ(sync.call(msg::VarSet{"a", Variant(int64_t{1})})->kind(), Code::reply_ok);
  const uint16_t cmd = addChannel(sat, "cmd");  // before the module: told as there already
  startModules("test_watch_calls");
  auto events =
      as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_watch_calls.events"}));
  ASSERT_TRUE(events);
  ASSERT_TRUE(sat.send(msg::Subscribe{1, events->info.id}));
  ASSERT_TRUE(sat.send(msg::DbSetCurrent{2, "guest"}));  // a round trip: subscribed now
  ASSERT_TRUE(sat.waitFor(Code::ev_db_changed));
  auto next = [&](int timeout_ms = 5000) {
    auto d = as<msg::EvData>(sat.waitFor(Code::ev_data, timeout_ms));
    return d ? std::string(d->payload.bytes) : std::string();
  };
  ASSERT_EQ(sync.call(msg::DbSelect{"test_watch_calls"})->kind(), Code::reply_ok);
  auto hub = as<msg::ReplyValue>(sync.call(msg::VarGet{"hub"}));
  ASSERT_TRUE(hub);
  EXPECT_EQ(hub->value, Variant(server_->hubName()));
  ASSERT_EQ(sync.call(msg::DbSelect{"shared"})->kind(), Code::reply_ok);

  // Changes as they come, whoever makes them.
  const uint16_t cam = addChannel(sat, "cam");
  EXPECT_EQ(next(), "added guest.cam 1 application/octet-stream");
  ASSERT_EQ(sync.call(msg::VarSet{"b", Variant("two")})->kind(), Code::reply_ok);
  EXPECT_EQ(next(), "set b=\"two\"");
  ASSERT_TRUE(sat.send(msg::Publish{cmd, msg::Rest{"remove b"}}));  // db_remove by the module
  EXPECT_EQ(next(), "del b");
  EXPECT_EQ(sync.call(msg::VarGet{"b"})->kind(), Code::reply_error);
  ASSERT_TRUE(sat.send(msg::ChanRemove{3, cam}));
  EXPECT_EQ(next(), "removed guest.cam");
  // Unwatched: nothing more.
  ASSERT_TRUE(sat.send(msg::Publish{cmd, msg::Rest{"unwatch"}}));
  ASSERT_TRUE(sat.send(msg::DbSetCurrent{4, "guest"}));  // a round trip: the module read it
  ASSERT_TRUE(sat.waitFor(Code::ev_db_changed));
  ASSERT_EQ(sync.call(msg::VarSet{"c", Variant(int64_t{3})})->kind(), Code::reply_ok);
  EXPECT_NE(addChannel(sat, "late"), 0);
  EXPECT_EQ(next(300), "");
}

// Retained messages (ABI 1.9): a subscriber that comes later gets each key's last message, oldest
// first, before live ones; cleared keys are gone; past the limit nothing is kept or sent.
TEST_F(ModuleChannels, RetainedMessagesReachEachLaterSubscriberFirst) {
  LogCapture logs;
  startHub();
  startModules("test_retained_latch");
  TestClient sat = flowClient();
  TestClient probe = flowClient();
  TestClient sync = syncClient();
  auto info =
      as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_retained_latch.latched"}));
  ASSERT_TRUE(info);
  const uint16_t latched = info->info.id;
  EXPECT_EQ(*info->info.props.find("retained"), Variant(true));
  ASSERT_TRUE(probe.send(msg::Subscribe{1, latched}));
  const uint16_t set = addChannel(sat, "set");
  ASSERT_TRUE(sat.waitFor(Code::ev_start_publish));  // the module subscribed
  // What `probe` (there from the start) gets live: every message; `until` is the last.
  auto send = [&](std::initializer_list<const char*> texts, const std::string& until) {
    for (const char* t : texts) ASSERT_TRUE(sat.send(msg::Publish{set, msg::Rest{t}}));
    for (;;) {
      auto d = as<msg::EvData>(probe.waitFor(Code::ev_data));
      ASSERT_TRUE(d) << "waiting for " << until;
      if (d->payload.bytes == until) break;
    }
  };
  // Each new subscriber's first messages, up to the live `marker` that follows them.
  auto firstMessages = [&](const std::string& marker) {
    TestClient late = flowClient();
    // A barrier: the hub handles `late`'s frames in order, so once the owner of a fresh channel
    // hears that `late` subscribed to it, `late` is subscribed to `latched` too.
    const uint16_t barrier = addChannel(sat, "barrier_" + marker);
    EXPECT_TRUE(late.send(msg::Subscribe{2, latched}));
    EXPECT_TRUE(late.send(msg::Subscribe{3, barrier}));
    EXPECT_TRUE(sat.waitFor(Code::ev_start_publish));
    send({("!" + marker).c_str()}, marker);
    std::vector<std::string> got;
    for (;;) {
      auto d = as<msg::EvData>(late.waitFor(Code::ev_data));
      if (!d) break;
      got.emplace_back(d->payload.bytes);
      if (got.back() == marker) break;
    }
    return got;
  };
  send({"a=1", "b=2", "a=3", "!live"}, "live");
  // The module's own subscriptions: each new one gets the kept messages, the others do not
  // again (one subscription of the module's flow in the hub for both).
  auto heard = [&] {
    std::vector<std::string> out;
    for (const auto& line : logs.lines()) {
      if (line.rfind("LATCH-HEARD ", 0) == 0) out.push_back(line.substr(12));
    }
    return out;
  };
  send({"?", "!one"}, "one");
  EXPECT_TRUE(eventually([&] { return heard().size() >= 3; }));
  EXPECT_EQ(heard(), (std::vector<std::string>{"1:2", "1:3", "1:one"}));
  send({"?", "!two"}, "two");
  EXPECT_TRUE(eventually([&] { return heard().size() >= 7; }));
  EXPECT_EQ(heard(),
            (std::vector<std::string>{"1:2", "1:3", "1:one", "2:2", "2:3", "1:two", "2:two"}));
  EXPECT_EQ(firstMessages("m1"), (std::vector<std::string>{"2", "3", "m1"}));
  EXPECT_EQ(firstMessages("m2"), (std::vector<std::string>{"2", "3", "m2"}));  // each one
  send({"-b", "!cleared"}, "cleared");
  EXPECT_EQ(firstMessages("m3"), (std::vector<std::string>{"3", "m3"}));
  send({"-", "!all"}, "all");
  EXPECT_EQ(firstMessages("m4"), (std::vector<std::string>{"m4"}));
  // 64 keys at most: the 65th is refused, neither kept nor sent.
  for (int i = 0; i < 64; ++i) {
    const std::string kv = "k" + std::to_string(i) + "=" + std::to_string(i);
    ASSERT_TRUE(sat.send(msg::Publish{set, msg::Rest{kv}}));
  }
  send({"k64=over", "!full"}, "full");
  EXPECT_TRUE(logs.sawTag("LATCH-REFUSED")) << "the 65th key";
  const auto kept = firstMessages("m5");
  ASSERT_EQ(kept.size(), 65u);
  EXPECT_EQ(kept.front(), "0");
  EXPECT_EQ(kept[63], "63");
}

}  // namespace
}  // namespace skr::test
