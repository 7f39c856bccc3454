// SPDX-License-Identifier: Apache-2.0
// The nats-bridge module (docs/fleet.md) against real nats-server processes on loopback: hubs
// started as processes with the module, satellites on them, and a raw NATS client for the
// fleet's side.
#include "named_hub.h"
#include "nats_server.h"

#include <skrobot/support/json.hpp>

namespace skr::sat::test {
namespace {

using flow::Variant;

Json::Value json(const std::string& text) {
  auto v = support::parseJson(text);
  return v ? *v : Json::Value();
}

// The bridge's module entry for a hub's "modules" array.
std::string bridge(const std::string& config) {
  return R"([{"name": "nats-bridge", "config": )" + config + "}]";
}

std::string servers(const std::vector<const NatsServer*>& list) {
  std::string out = "[";
  for (size_t i = 0; i < list.size(); ++i) out += (i ? ", \"" : "\"") + list[i]->url() + "\"";
  return out + "]";
}

// The last status the bridge published, read from its status channel by `s`.
Json::Value lastStatus(SatOnThread& s) {
  const auto all = s.events.with("data:nats-bridge.status:");
  if (all.empty()) return Json::Value();
  return json(all.back());
}

// Stops the hub and expects a clean exit: under the sanitizers a leak or a crash in the bridge's
// stop (its threads, the client's) makes it fail.
void expectCleanStop(NamedHub& h) {
  EXPECT_EQ(h.hub->stop(), 0) << h.hub->log();
}

class NatsBridge : public ::testing::Test {
 protected:
  void SetUp() override {
    nats = std::make_unique<NatsServer>(dir.path(), "solo");
    ASSERT_TRUE(nats->start()) << nats->log();
  }
  // A hub named `name` with the bridge on `nats` and `config_members` (", "-separated members).
  std::unique_ptr<NamedHub> hub(const std::string& name, const std::string& config_members) {
    auto h = std::make_unique<NamedHub>(name);
    h->modules = bridge(R"({"servers": )" + servers({nats.get()}) +
                        (config_members.empty() ? "" : ", " + config_members) + "}");
    EXPECT_TRUE(h->start()) << h->hub->log();
    EXPECT_TRUE(h->hub->waitLog("NATS-CONNECTED")) << h->hub->log();
    return h;
  }
  TempDir dir;
  std::unique_ptr<NatsServer> nats;
};

TEST_F(NatsBridge, ExportsChannelsUnderItsPrefixWithTheirPropertiesAndImportsOnDemand) {
  auto robot = hub("robot1", R"("export": ["guest.**", "!guest.secret"],
      "import": [{"subject": "sensors.temp", "as": "temp", "mime": "text/plain"}])");
  RawNats fleet(nats->url());
  ASSERT_TRUE(fleet.ok());
  natsSubscription* counter = fleet.subscribe("skrobot.robot1.guest.counter.v2");
  natsSubscription* secret = fleet.subscribe("skrobot.robot1.guest.secret");
  auto owner = robot->satellite("owner");
  ASSERT_TRUE(owner->on([](Satellite& s) {
    return s.addChannel({.name = "counter.v2",
                         .mime = "text/plain",
                         .props = Variant::Map{{"unit", "ticks"}}}) &&
           s.addChannel({.name = "secret"});
  }));
  // The bridge subscribes to what it exports: the owner hears it has a subscriber.
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.counter.v2") == 1; }))
      << robot->hub->log();
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(owner->on([i](Satellite& s) {
      return s.publish("counter.v2", std::to_string(i)) && s.publish("secret", "x");
    }));
  }
  for (int i = 0; i < 5; ++i) EXPECT_EQ(RawNats::next(counter), std::to_string(i));
  EXPECT_EQ(RawNats::next(secret, 200), std::nullopt);  // excluded by "!guest.secret"
  EXPECT_EQ(owner->events.count("start:guest.secret"), 0u);

  // Its properties, asked for on the companion subject.
  auto props = fleet.request("skrobot.robot1._props.guest.counter.v2", "");
  ASSERT_TRUE(props);
  const Json::Value p = json(props->data);
  EXPECT_EQ(p["channel"].asString(), "guest.counter.v2");
  EXPECT_EQ(p["mime"].asString(), "text/plain");
  EXPECT_EQ(p["props"]["unit"].asString(), "ticks") << props->data;

  // An import is subscribed on NATS only while someone here listens: what is published before
  // reaches nobody (the bridge's counter stays at 0).
  auto viewer = robot->satellite("viewer");
  viewer->on([](Satellite& s) { s.subscribe("nats-bridge.status"); });
  ASSERT_TRUE(eventually([&] { return !lastStatus(*viewer).isNull(); }));
  ASSERT_TRUE(fleet.publish("sensors.temp", "19.0"));
  viewer->on([](Satellite& s) { s.subscribe("nats-bridge.temp"); });
  ASSERT_TRUE(eventually([&] { return viewer->events.count("subscribed:nats-bridge.temp") == 1; }));
  // The bridge's NATS subscription is made by its thread: publish until one gets through.
  ASSERT_TRUE(eventually([&] {
    fleet.publish("sensors.temp", "21.5");
    return viewer->events.count("data:nats-bridge.temp:21.5") > 0;
  })) << robot->hub->log();
  EXPECT_EQ(viewer->events.count("data:nats-bridge.temp:19.0"), 0u);
  viewer->on([](Satellite& s) { s.unsubscribe("nats-bridge.temp"); });
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));  // a status after it
  const auto before = lastStatus(*viewer)["in_msgs"].asUInt64();
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(fleet.publish("sensors.temp", "22"));
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));
  EXPECT_EQ(lastStatus(*viewer)["in_msgs"].asUInt64(), before) << robot->hub->log();
  EXPECT_EQ(lastStatus(*viewer)["state"].asString(), "connected");
  expectCleanStop(*robot);
}

TEST_F(NatsBridge, TwoRobotsShareACameraAndAServiceThroughNatsWithoutAHubLink) {
  auto r1 = hub("robot1", R"("export": ["guest.camera", "guest.echo"])");
  auto r2 = hub("robot2", R"("import": [
      {"subject": "skrobot.robot1.guest.camera", "as": "r1-camera", "mime": "image/x-rgb"},
      {"subject": "skrobot.robot1.guest.echo", "as": "r1-echo", "service": true},
      {"subject": "nobody.home", "as": "void", "service": true},
      {"subject": "fleet.slow", "as": "slow", "service": true, "timeout_ms": 300}])");
  auto camera = r1->satellite("camera");
  ASSERT_TRUE(camera->on([](Satellite& s) {
    return s.addChannel({.name = "camera", .mime = "image/x-rgb"}) &&
           s.addChannel({.name = "echo", .kind = flow::ChannelKind::service});
  }));
  camera->on([](Satellite& s) {
    s.serviceRequest.connect(&s, [&s](const Request& r) {
      (void)s.respond(r, Variant::Map{{"command", r.command}, {"value", r.value}});
    });
  });
  auto viewer = r2->satellite("viewer");
  viewer->on([](Satellite& s) { s.subscribe("nats-bridge.r1-camera"); });
  ASSERT_TRUE(eventually([&] { return viewer->events.count("subscribed:nats-bridge.r1-camera"); }));

  // 640x360 RGB frames, each byte-for-byte as sent.
  std::vector<std::string> frames;
  for (int f = 0; f < 10; ++f) {
    std::string frame(640 * 360 * 3, '\0');
    for (size_t i = 0; i < frame.size(); ++i) frame[i] = static_cast<char>((i * 7 + f) & 0xFF);
    frames.push_back(std::move(frame));
  }
  // Until the first one crosses (robot2's NATS subscription is made when the viewer came).
  ASSERT_TRUE(eventually([&] {
    (void)camera->on([&](Satellite& s) { return s.publish("camera", frames[0]); });
    return viewer->events.count("data:nats-bridge.r1-camera:") > 0;
  })) << r1->hub->log()
      << r2->hub->log();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the last of those arrived
  viewer->events.clear();
  for (const auto& f : frames) {
    ASSERT_TRUE(camera->on([&](Satellite& s) { return s.publish("camera", f); }));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:nats-bridge.r1-camera:") >= 10; }))
      << viewer->events.count("data:nats-bridge.r1-camera:");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ASSERT_EQ(viewer->events.count("data:nats-bridge.r1-camera:"), 10u);
  const auto got = viewer->events.with("data:nats-bridge.r1-camera:");
  for (size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(got[i] == frames[i]) << "frame " << i;

  // A call of robot1's service from robot2, as a local service channel.
  std::mutex m;
  std::vector<Response> answers;
  auto keep = [&](const Response& r) {
    std::lock_guard lock(m);
    answers.push_back(r);
  };
  auto caller = r2->satellite("caller");
  ASSERT_TRUE(eventually([&] {
    return caller->on([](Satellite& s) { return s.channel("nats-bridge.r1-echo") != nullptr; });
  }));
  ASSERT_TRUE(caller->on([&](Satellite& s) {
    return s.request("nats-bridge.r1-echo", "shout", Variant::Map{{"n", int64_t{7}}}, keep).ok();
  }));
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(m);
    return answers.size() == 1;
  }));
  EXPECT_TRUE(answers[0].ok());
  EXPECT_EQ(*answers[0].value.find("command"), Variant("shout"));
  EXPECT_EQ(*answers[0].value.find("value")->find("n"), Variant(int64_t{7}));
  // Nobody serves the subject: an error value at once; a server too slow: a timeout.
  RawNats slow(nats->url());
  ASSERT_TRUE(slow.serve("fleet.slow", [](const std::string&) {
    std::this_thread::sleep_for(std::chrono::milliseconds(800));
    return std::string("\"late\"");
  }));
  ASSERT_TRUE(caller->on([&](Satellite& s) {
    return s.request("nats-bridge.void", "", Variant(), keep).ok() &&
           s.request("nats-bridge.slow", "", Variant(), keep).ok();
  }));
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(m);
    return answers.size() == 3;
  }));
  EXPECT_EQ(*answers[1].value.find("error"), Variant("no_responders"));
  EXPECT_EQ(*answers[2].value.find("error"), Variant("timeout"));

  // The fleet calls robot1's service directly, with a command header; bad JSON is refused.
  RawNats fleet(nats->url());
  auto direct = fleet.request("skrobot.robot1.guest.echo", R"({"a": 1})", "ping");
  ASSERT_TRUE(direct);
  EXPECT_EQ(direct->error, "");
  const Json::Value d = json(direct->data);
  EXPECT_EQ(d["command"].asString(), "ping") << direct->data;
  EXPECT_EQ(d["value"]["a"].asInt(), 1);
  auto bad = fleet.request("skrobot.robot1.guest.echo", "{not json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->error, "bad_request");
  expectCleanStop(*r1);
  expectCleanStop(*r2);
}

TEST_F(NatsBridge, RequestsFromNatsActAsTheBridgesAccount) {
  auto robot = std::make_unique<NamedHub>("robot1");
  robot->account = "fleet";
  robot->rules = {{"call", {"guest.echo"}}};
  robot->modules = R"([{"name": "nats-bridge", "account": "fleet", "config": {"servers": )" +
                   servers({nats.get()}) + R"(, "export": ["guest.**"]}}])";
  ASSERT_TRUE(robot->start()) << robot->hub->log();
  ASSERT_TRUE(robot->hub->waitLog("NATS-CONNECTED")) << robot->hub->log();
  auto owner = robot->satellite("owner");
  ASSERT_TRUE(owner->on([](Satellite& s) {
    return s.addChannel({.name = "echo", .kind = flow::ChannelKind::service}) &&
           s.addChannel({.name = "admin", .kind = flow::ChannelKind::service});
  }));
  owner->on([](Satellite& s) {
    s.serviceRequest.connect(&s, [&s](const Request& r) { (void)s.respond(r, Variant("done")); });
  });
  ASSERT_TRUE(robot->hub->waitLog("NATS-EXPORT guest.admin")) << robot->hub->log();
  RawNats fleet(nats->url());
  auto allowed = fleet.request("skrobot.robot1.guest.echo", "1");
  ASSERT_TRUE(allowed);
  EXPECT_EQ(allowed->error, "");
  EXPECT_EQ(allowed->data, "\"done\"");
  auto refused = fleet.request("skrobot.robot1.guest.admin", "1");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->error, "refused") << refused->data;
  // The refusal is the hub's, told in its log as for any module's call.
  EXPECT_NE(robot->hub->log().find("service_request"), std::string::npos) << robot->hub->log();
}

TEST_F(NatsBridge, ANamedDatabaseIsMirroredToAKeyValueBucketBothWays) {
  auto robot = std::make_unique<NamedHub>("robot1");
  robot->modules = bridge(R"({"servers": )" + servers({nats.get()}) +
                          R"(, "kv": [{"db": "calibration", "bucket": "calib"}]})");
  ASSERT_TRUE(robot->start()) << robot->hub->log();
  auto sat = robot->satellite("tool");
  auto db = [&](auto fn) {
    return sat->on([&](Satellite& s) {
      auto* sync = s.syncClient().value();
      return fn(*sync);
    });
  };
  // The database is made after the bridge started: the mirror waits for it.
  ASSERT_TRUE(db([](SyncClient& c) {
    return c.createDatabase("calibration").ok() && c.selectDatabase("calibration").ok() &&
           c.set("arm.offset", Variant(1.5)).ok() && c.set("odd key=1", Variant("x")).ok();
  }));
  RawNats fleet(nats->url());
  ASSERT_TRUE(eventually([&] { return fleet.kvGet("calib", "arm.offset") == "1.5"; }))
      << robot->hub->log();
  ASSERT_TRUE(eventually([&] { return fleet.kvGet("calib", "odd=20key=3D1") == "\"x\""; }));
  // The other way: a value written in the bucket by another program, then deleted.
  uint64_t rev = 0;
  ASSERT_EQ(kvStore_PutString(&rev, fleet.kv("calib"), "gain", R"({"p": 2})"), NATS_OK);
  ASSERT_TRUE(eventually([&] {
    return db([](SyncClient& c) {
      auto v = c.get("gain");
      return v.ok() && v->find("p") != nullptr && *v->find("p") == Variant(int64_t{2});
    });
  })) << robot->hub->log();
  ASSERT_EQ(kvStore_Delete(fleet.kv("calib"), "gain"), NATS_OK);
  ASSERT_TRUE(eventually([&] { return db([](SyncClient& c) { return !c.get("gain").ok(); }); }));
  // A local change after that still goes out (nothing echoes back and forth).
  ASSERT_TRUE(db([](SyncClient& c) { return c.set("arm.offset", Variant(2.5)).ok(); }));
  ASSERT_TRUE(eventually([&] { return fleet.kvGet("calib", "arm.offset") == "2.5"; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(db([](SyncClient& c) {
              auto v = c.get("arm.offset");
              return v ? *v : Variant();
            }),
            Variant(2.5));
  expectCleanStop(*robot);
}

TEST_F(NatsBridge, BadConfigIsReportedWithItsPathAndTheHubGoesOn) {
  auto robot = std::make_unique<NamedHub>("robot1");
  robot->modules = bridge(R"({"servers": [""], "import": [
      {"subject": "a..b", "as": "x"}, {"subject": "ok", "as": "x"},
      {"subject": "svc.*", "as": "s", "service": true, "colour": "red"}],
      "export": ["a b"], "kv": [{"db": "calibration", "bucket": "no.dots"}]})");
  ASSERT_TRUE(robot->start()) << robot->hub->log();
  const std::string log = robot->hub->log();
  for (const char* line :
       {"$.modules[0].config.servers[0]: is empty", "$.modules[0].config.import[0].subject",
        "$.modules[0].config.import[1].as: \"x\" is taken",
        "$.modules[0].config.import[2].colour: unknown key",
        "$.modules[0].config.import[2].subject: not a NATS subject without wildcards",
        "$.modules[0].config.export: pattern 1 'a b'", "$.modules[0].config.kv[0].bucket"}) {
    EXPECT_NE(log.find(line), std::string::npos) << line << "\n" << log;
  }
  EXPECT_NE(log.find("MODULE-INIT"), std::string::npos);
  auto s = robot->satellite("still-here");  // the hub runs without the module
  EXPECT_TRUE(s->connected());
}

TEST_F(NatsBridge, NoServerAtStartTheHubRunsAndTheBridgeConnectsWhenOneComes) {
  NatsServer later(dir.path(), "later");
  auto robot = std::make_unique<NamedHub>("robot1");
  robot->modules = bridge(R"({"servers": )" + servers({&later}) +
                          R"(, "export": ["guest.**"], "reconnect_max_ms": 200})");
  ASSERT_TRUE(robot->start()) << robot->hub->log();
  ASSERT_TRUE(robot->hub->waitLog("NATS-CONNECT-RETRY")) << robot->hub->log();
  auto owner = robot->satellite("owner");
  owner->on([](Satellite& s) { s.subscribe("nats-bridge.status"); });
  ASSERT_TRUE(eventually([&] { return lastStatus(*owner)["state"].asString() == "connecting"; }));
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.addChannel({.name = "beat"}); }));
  ASSERT_TRUE(later.start());
  ASSERT_TRUE(robot->hub->waitLog("NATS-CONNECTED")) << robot->hub->log();
  RawNats fleet(later.url());
  natsSubscription* beat = fleet.subscribe("skrobot.robot1.guest.beat");
  ASSERT_TRUE(eventually([&] {
    (void)owner->on([](Satellite& s) { return s.publish("beat", "b"); });
    return RawNats::next(beat, 50) == "b";
  }));
  EXPECT_TRUE(eventually([&] { return lastStatus(*owner)["state"].asString() == "connected"; }));
}

// Three nats-server nodes in a cluster; robot1's camera crosses to robot2 at 50 Hz while the node
// robot1's bridge is connected to is killed, then while the whole cluster is down and back.
TEST_F(NatsBridge, ACameraKeepsCrossingAClusterThatLosesANodeAndComesBackWhole) {
  nats.reset();  // this test's servers are a cluster
  std::vector<std::unique_ptr<NatsServer>> nodes;
  std::vector<int> cluster_ports{freePort(), freePort(), freePort()};
  for (int i = 0; i < 3; ++i) {
    nodes.push_back(std::make_unique<NatsServer>(dir.path(), "n" + std::to_string(i), false));
    std::vector<int> routes;
    for (int j = 0; j < 3; ++j) {
      if (j != i) routes.push_back(cluster_ports[j]);
    }
    nodes.back()->cluster(cluster_ports[i], routes);
  }
  for (auto& n : nodes) ASSERT_TRUE(n->start()) << n->log();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // routes formed
  auto make = [&](const std::string& name, std::vector<const NatsServer*> order,
                  const std::string& members) {
    auto h = std::make_unique<NamedHub>(name);
    h->modules = bridge(R"({"servers": )" + servers(order) +
                        R"(, "reconnect_min_ms": 20, "reconnect_max_ms": 200, )" + members + "}");
    EXPECT_TRUE(h->start()) << h->hub->log();
    EXPECT_TRUE(h->hub->waitLog("NATS-CONNECTED")) << h->hub->log();
    return h;
  };
  auto r1 = make("robot1", {nodes[0].get(), nodes[1].get(), nodes[2].get()},
                 R"("export": ["guest.camera"])");
  auto r2 = make("robot2", {nodes[2].get(), nodes[1].get(), nodes[0].get()},
                 R"("import": [{"subject": "skrobot.robot1.guest.camera", "as": "cam"}])");
  auto camera = r1->satellite("camera");
  ASSERT_TRUE(camera->on([](Satellite& s) { return s.addChannel({.name = "camera"}); }));
  auto viewer = r2->satellite("viewer");
  viewer->on([](Satellite& s) { s.subscribe("nats-bridge.cam"); });

  // The camera runs on its own thread at 50 Hz; each frame holds its send time.
  std::atomic<bool> running{true};
  std::thread pump([&] {
    while (running) {
      const auto now = std::chrono::steady_clock::now().time_since_epoch().count();
      std::string frame(8 * 1024, 'f');
      frame.replace(0, 20, std::to_string(now));
      (void)camera->on([&](Satellite& s) { return s.publish("camera", frame); });
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  auto received = [&] { return viewer->events.count("data:nats-bridge.cam:"); };
  ASSERT_TRUE(eventually([&] { return received() > 20; })) << r2->hub->log();

  // The longest time without a frame while `fault` happens and is repaired.
  auto worstGap = [&](const std::function<void()>& fault, int settle_ms) {
    std::atomic<bool> watching{true};
    int64_t worst = 0;
    std::thread watch([&] {
      size_t last_count = received();
      auto last = std::chrono::steady_clock::now();
      while (watching) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        const size_t n = received();
        const auto now = std::chrono::steady_clock::now();
        if (n != last_count) {
          last_count = n;
          last = now;
        }
        worst = std::max<int64_t>(
            worst, std::chrono::duration_cast<std::chrono::milliseconds>(now - last).count());
      }
    });
    fault();
    const size_t after_fault = received();
    EXPECT_TRUE(eventually([&] { return received() > after_fault + 25; }, 30000))
        << r1->hub->log() << r2->hub->log();
    std::this_thread::sleep_for(std::chrono::milliseconds(settle_ms));
    watching = false;
    watch.join();
    return worst;
  };
  // The node robot1's bridge is connected to (the client shuffles the list it was given).
  auto watcher = r1->satellite("status");
  watcher->on([](Satellite& s) { s.subscribe("nats-bridge.status"); });
  ASSERT_TRUE(eventually([&] { return !lastStatus(*watcher)["server"].asString().empty(); }));
  const std::string server = lastStatus(*watcher)["server"].asString();
  NatsServer* victim = nullptr;
  for (auto& n : nodes) {
    if (n->url() == server) victim = n.get();
  }
  ASSERT_NE(victim, nullptr) << server;
  const int64_t node_gap = worstGap([&] { victim->kill(); }, 200);
  EXPECT_TRUE(r1->hub->waitLog("NATS-RECONNECTED")) << r1->hub->log();
  std::printf("[ figures ] one node of three killed: longest gap %lld ms\n",
              static_cast<long long>(node_gap));

  const int64_t cluster_gap = worstGap(
      [&] {
        for (auto& n : nodes) n->kill();
        std::this_thread::sleep_for(std::chrono::milliseconds(1000));
        for (auto& n : nodes) ASSERT_TRUE(n->start()) << n->log();
      },
      200);
  std::printf("[ figures ] whole cluster down 1 s and back: longest gap %lld ms\n",
              static_cast<long long>(cluster_gap));
  running = false;
  pump.join();
  EXPECT_TRUE(r2->hub->log().find("NATS-RECONNECTED") != std::string::npos);
  expectCleanStop(*r1);
  expectCleanStop(*r2);
}

}  // namespace
}  // namespace skr::sat::test
