// SPDX-License-Identifier: Apache-2.0
// flowctl, the built binary, against a real hub: every command and its error cases.
#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

using flow::Variant;

struct Ran {
  int code = -1;
  std::string out;  // stdout and stderr
};

class Flowctl : public SatTest {
 protected:
  void SetUp() override { startHub(); }

  Ran flowctl(std::vector<std::string> args, const std::string& input = {},
              std::vector<std::string> env = {}) {
    args.insert(args.begin(), FLOWCTL_BIN);
    if (env.empty()) env.push_back("ROBOT_ADDRESS=" + address());
    Child c(args, env, dir_.path() / ("flowctl-" + std::to_string(++runs_) + ".out"), input);
    Ran r;
    r.code = c.wait();
    r.out = c.output();
    return r;
  }
  std::unique_ptr<Child> background(std::vector<std::string> args) {
    args.insert(args.begin(), FLOWCTL_BIN);
    return std::make_unique<Child>(args, std::vector<std::string>{"ROBOT_ADDRESS=" + address()},
                                   dir_.path() / ("bg-" + std::to_string(++runs_) + ".out"));
  }
  // A satellite owning guest.counter (streaming) and guest.adder (a service).
  std::unique_ptr<SatOnThread> owner() {
    auto s = satellite("owner");
    s->on([](Satellite& x) {
      ASSERT_TRUE(x.addChannel(
          {.name = "counter", .mime = "text/plain", .props = Variant::Map{{"unit", "ticks"}}}));
      ASSERT_TRUE(x.addChannel({.name = "adder", .kind = flow::ChannelKind::service}));
      x.serviceRequest.connect(&x, [&x](const Request& r) {
        if (r.command == "add") (void)x.respond(r, *r.value.asList()->at(0).asInt64() + 1);
      });
    });
    EXPECT_TRUE(eventually([&] { return s->events.count("ready:") == 2; }));
    return s;
  }
  int runs_ = 0;
};

bool has(const Ran& r, const std::string& text) {
  return r.out.find(text) != std::string::npos;
}

TEST_F(Flowctl, HelpAndUsageErrors) {
  auto help = flowctl({"--help"});
  EXPECT_EQ(help.code, 0);
  for (const char* word : {"ls", "echo", "pub", "call", "db", "skrobot user", "Exit codes"}) {
    EXPECT_TRUE(has(help, word)) << word << "\n" << help.out;
  }
  EXPECT_TRUE(has(flowctl({"help", "pub"}), "--repeat"));
  EXPECT_TRUE(has(flowctl({"echo", "--help"}), "--format"));
  EXPECT_EQ(flowctl({"frobnicate"}).code, 2);
  EXPECT_EQ(flowctl({}).code, 2);
  EXPECT_EQ(flowctl({"ls", "--bogus"}).code, 2);
  EXPECT_EQ(flowctl({"db", "get"}).code, 2);
  EXPECT_EQ(flowctl({"echo", "x", "--format", "morse"}).code, 2);
  auto bad_env = flowctl({"ls"}, {}, {"ROBOT_ADDRESS=pigeon:home"});
  EXPECT_EQ(bad_env.code, 2);
  EXPECT_TRUE(has(bad_env, "ROBOT_ADDRESS")) << bad_env.out;
}

// Every command has a help text (flowctl help NAME, or NAME --help): those that flowctl help
// --markdown lists, bw (on hz's line) and help.
TEST_F(Flowctl, EveryCommandHasHelp) {
  auto markdown = flowctl({"help", "--markdown"});
  ASSERT_EQ(markdown.code, 0) << markdown.out;
  std::vector<std::string> names{"bw", "help"};
  std::istringstream lines(markdown.out);
  const std::string item = "- `flowctl ";
  for (std::string line; std::getline(lines, line);) {
    ASSERT_TRUE(line.starts_with(item)) << line;
    names.push_back(line.substr(item.size(), line.find_first_of(" `", item.size()) - item.size()));
  }
  EXPECT_GE(names.size(), 23u) << markdown.out;
  for (const auto& name : names) {
    auto help = flowctl({"help", name});
    EXPECT_EQ(help.code, 0) << name << ": " << help.out;
    EXPECT_TRUE(help.out.starts_with("usage: flowctl ") && has(help, name)) << help.out;
    if (name != "help") {
      EXPECT_EQ(flowctl({name, "--help"}).out, help.out) << name;
    }
  }
}

TEST_F(Flowctl, NoHubAndWrongPassword) {
  auto none = flowctl({"ls", "--address", "local:" + (dir_.path() / "nothing").string()});
  EXPECT_EQ(none.code, 3);
  EXPECT_TRUE(has(none, "no hub at local:")) << none.out;
  EXPECT_TRUE(has(none, "is skrobot running?")) << none.out;
  auto echo = background({"echo", "guest.later", "--wait"});
  // Stopped once flowctl's satellite is in flow: a flow of the hub's seen in two polls 300 ms
  // apart (echo's first connection, a synchronous one that looks the channel up, is gone by
  // then). A fixed wait lost the race under ASan.
  std::set<uint64_t> seen;
  ASSERT_TRUE(eventually([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    auto v = hubStats();
    if (!v) return false;
    std::set<uint64_t> now;
    for (const auto& fl : *v->find("flows")->asList()) {
      if (*fl.find("client") != Variant("stats")) now.insert(uint64_t(*fl.find("id")->asInt64()));
    }
    const bool again = std::ranges::any_of(now, [&](uint64_t id) { return seen.contains(id); });
    seen = std::move(now);
    return again;
  })) << echo->output();
  hub_->stop();
  EXPECT_EQ(echo->wait(), 3);
  EXPECT_TRUE(echo->waitOutput("lost the hub")) << echo->output();
  startHub();
  auto refused = flowctl({"--password", "wrong", "ls"});
  EXPECT_EQ(refused.code, 4);
  EXPECT_TRUE(has(refused, "wrong user name or password")) << refused.out;
}

TEST_F(Flowctl, AdministrationNeedsAnAdministrator) {
  // guest (the development account) is no administrator: refused with exit 7, and the usage of
  // each command is checked before connecting.
  for (const auto& args :
       std::vector<std::vector<std::string>>{{"flows"}, {"kick", "1"}, {"chan", "rm", "guest.x"}}) {
    auto r = flowctl(args);
    EXPECT_EQ(r.code, 7) << r.out;
    EXPECT_TRUE(has(r, "not an administrator")) << r.out;
  }
  EXPECT_EQ(flowctl({"kick"}).code, 2);
  EXPECT_EQ(flowctl({"chan", "del", "x"}).code, 2);
}

TEST_F(Flowctl, ListsChannels) {
  EXPECT_TRUE(has(flowctl({"ls", "guest.*"}), "no channels"));
  EXPECT_TRUE(has(flowctl({"ls"}), "hub.stats"));  // the hub's own statistics
  auto o = owner();
  auto ls = flowctl({"ls"});
  EXPECT_EQ(ls.code, 0);
  for (const char* text : {"guest.counter", "streaming", "guest.adder", "service", "text/plain",
                           "{\"unit\":\"ticks\"}", "SUBS"}) {
    EXPECT_TRUE(has(ls, text)) << text << "\n" << ls.out;
  }
  auto json = flowctl({"--json", "ls", "*.counter"});
  ASSERT_EQ(json.code, 0);
  auto v = flow::variantFromJsonText(json.out.substr(0, json.out.find('\n')));
  ASSERT_TRUE(v) << json.out;
  ASSERT_EQ(v->asList()->size(), 1u);
  const Variant& c = v->asList()->at(0);
  EXPECT_EQ(*c.find("name"), Variant("guest.counter"));
  EXPECT_EQ(*c.find("kind"), Variant("streaming"));
  EXPECT_EQ(*c.find("owner"), Variant("guest"));
  EXPECT_EQ(*c.find("props")->find("unit"), Variant("ticks"));

  // Patterns (docs/flow-protocol.md): '**' with an exclusion, and a bad pattern is a usage error.
  auto some = flowctl({"ls", "guest.**", "!*.adder"});
  EXPECT_TRUE(has(some, "guest.counter")) << some.out;
  EXPECT_FALSE(has(some, "guest.adder")) << some.out;
  EXPECT_TRUE(has(flowctl({"ls", "nobody.*"}), "no channels"));
  auto bad = flowctl({"ls", "guest.***"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_TRUE(has(bad, "pattern 1 'guest.***'")) << bad.out;
}

TEST_F(Flowctl, EchoAsksForItsQueue) {
  EXPECT_EQ(flowctl({"echo", "guest.q", "--queue", "lots"}).code, 2);
  // Above the hub's cap (64 MiB): clamped and said so; echo goes on and prints the data.
  auto echo = background({"echo", "guest.q", "--wait", "--count", "1", "--queue", "1073741824"});
  EXPECT_EQ(flowctl({"pub", "q", "frame", "--wait-ms", "5000"}).code, 0);
  EXPECT_EQ(echo->wait(), 0) << echo->output();
  EXPECT_NE(echo->output().find("flowctl: subscribed with a queue of 67108864 bytes"),
            std::string::npos)
      << echo->output();
  EXPECT_NE(echo->output().find("frame\n"), std::string::npos) << echo->output();
}

TEST_F(Flowctl, EchoAsksForARateCap) {
  EXPECT_EQ(flowctl({"echo", "guest.r", "--max-hz", "1.5"}).code, 2);
  EXPECT_EQ(flowctl({"echo", "guest.r", "--max-hz", "70000"}).code, 2);
  // The cap itself: subscribe_rate_test, sat_satellite_test.
  auto echo = background({"echo", "guest.r", "--wait", "--count", "1", "--max-hz", "2"});
  EXPECT_EQ(flowctl({"pub", "r", "frame", "--repeat", "30", "--rate", "100"}).code, 0);
  EXPECT_EQ(echo->wait(), 0) << echo->output();
  EXPECT_EQ(echo->output(), "frame\n");
}

TEST_F(Flowctl, DbWatchPrintsThePairsThenEachChange) {
  EXPECT_EQ(flowctl({"db", "set", "mode", "\"auto\""}).code, 0);
  auto watch = background({"db", "watch", "--count", "2"});
  ASSERT_TRUE(watch->waitOutput("(watching guest)")) << watch->output();
  EXPECT_EQ(flowctl({"db", "set", "speed", "2"}).code, 0);
  EXPECT_EQ(flowctl({"db", "del", "mode"}).code, 0);
  EXPECT_EQ(watch->wait(), 0) << watch->output();
  EXPECT_EQ(watch->output(), "mode = \"auto\"\n(watching guest)\nspeed = 2\nmode removed\n");
  EXPECT_EQ(flowctl({"db", "watch", "--db", "nothing"}).code, 5);
  EXPECT_EQ(flowctl({"db", "ls", "--count", "1"}).code, 2);
}

TEST_F(Flowctl, EchoWhatPubPublishes) {
  EXPECT_EQ(flowctl({"echo", "guest.nothing"}).code, 5);
  auto echo = background({"echo", "guest.hello", "--wait", "--count", "3"});
  auto pub = flowctl({"pub", "hello", "hi there", "--repeat", "3"});
  EXPECT_EQ(pub.code, 0) << pub.out;
  EXPECT_TRUE(has(pub, "published 3 messages (24 bytes) on guest.hello")) << pub.out;
  EXPECT_EQ(echo->wait(), 0) << echo->output();
  EXPECT_EQ(echo->output(), "hi there\nhi there\nhi there\n");

  // Formats: hex, and JSON of a binary Variant published with --variant.
  auto hex = background({"echo", "guest.bin", "--wait", "--count", "1", "--format", "hex"});
  EXPECT_EQ(flowctl({"pub", "guest.bin", "--wait-ms", "5000"}, std::string("\x01\xff", 2)).code, 0);
  EXPECT_EQ(hex->wait(), 0);
  EXPECT_EQ(hex->output(), "01ff\n");
  auto json =
      background({"--json", "echo", "guest.v", "--wait", "--count", "1", "--format", "json"});
  EXPECT_EQ(flowctl({"pub", "v", "--variant", R"({"x":[1,2]})", "--wait-ms", "5000"}).code, 0);
  EXPECT_EQ(json->wait(), 0);
  EXPECT_EQ(json->output(), "{\"bytes\":31,\"channel\":\"guest.v\",\"data\":{\"x\":[1,2]}}\n");

  // A payload from a file, and a rate.
  std::ofstream(dir_.path() / "payload.txt") << "from a file";
  auto rate = background({"echo", "guest.f", "--wait", "--count", "4"});
  auto file = flowctl({"pub", "f", "--file", (dir_.path() / "payload.txt").string(), "--repeat",
                       "4", "--rate", "20", "--wait-ms", "5000"});
  EXPECT_EQ(file.code, 0) << file.out;
  EXPECT_EQ(rate->wait(), 0);
  EXPECT_EQ(rate->output(), "from a file\nfrom a file\nfrom a file\nfrom a file\n");
}

TEST_F(Flowctl, SyncSourceAndFollower) {
  EXPECT_EQ(flowctl({"sync", "source", "clock"}).code, 2);  // no --hz
  EXPECT_EQ(flowctl({"sync", "follow", "guest.nothing"}).code, 5);
  auto source = background({"sync", "source", "clock", "--hz", "200"});
  ASSERT_TRUE(eventually([&] { return has(flowctl({"ls"}), "guest.clock"); })) << source->output();
  auto follow = flowctl({"--json", "sync", "follow", "guest.clock", "--count", "40"});
  EXPECT_EQ(follow.code, 0) << follow.out;
  // One line per pulse, then the summary.
  EXPECT_EQ(std::count(follow.out.begin(), follow.out.end(), '\n'), 41) << follow.out;
  const std::string summary = follow.out.substr(follow.out.rfind("{\"source\""));
  auto v = flow::variantFromJsonText(summary);
  ASSERT_TRUE(v) << summary;
  EXPECT_EQ(*v->find("pulses"), Variant(40));
  EXPECT_NEAR(*v->find("period_ms")->asDouble(), 5.0, 2.5) << summary;
  EXPECT_TRUE(v->find("period_error")->find("p99_us") != nullptr) << summary;
  EXPECT_EQ(*v->find("missed"), Variant(0)) << summary;
  // --every 0 is each pulse; the source prints its own figures when it stops.
  EXPECT_EQ(flowctl({"sync", "follow", "guest.clock", "--every", "0", "--count", "1"}).code, 0);
  source->signal(SIGINT);
  EXPECT_EQ(source->wait(), 0) << source->output();
  EXPECT_TRUE(has(Ran{0, source->output()}, "period error: p50")) << source->output();
}

TEST_F(Flowctl, PollPrintsTheLatestPayloadWhenItChanges) {
  EXPECT_EQ(flowctl({"poll", "guest.nothing"}).code, 5);
  auto o = owner();
  EXPECT_EQ(flowctl({"poll", "guest.adder"}).code, 1);  // a service
  auto poll = background({"--json", "poll", "guest.counter", "--interval", "20", "--count", "2"});
  // Publish until the poller has printed two different payloads.
  const auto lines = [&] {
    const std::string out = poll->output();
    return std::count(out.begin(), out.end(), '\n');
  };
  for (int i = 0; i < 200 && lines() < 2; ++i) {
    o->on([i](Satellite& x) { (void)x.publish("counter", "n" + std::to_string(i / 10)); });
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(poll->wait(), 0) << poll->output();
  const std::string out = poll->output();
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 2) << out;
  EXPECT_NE(out.find("\"seq\":"), std::string::npos) << out;
  EXPECT_NE(out.find("\"channel\":\"guest.counter\""), std::string::npos) << out;
}

TEST_F(Flowctl, EchoRateAndOthersChannels) {
  auto o = owner();
  auto rate = background({"echo", "guest.counter", "--rate"});
  ASSERT_TRUE(eventually([&] { return o->events.count("start:guest.counter") == 1; }));
  for (int i = 0; i < 30 && rate->output().find("msg/s") == std::string::npos; ++i) {
    o->on([](Satellite& x) { (void)x.publish("counter", "0123456789"); });
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(rate->waitOutput("guest.counter: ")) << rate->output();
  EXPECT_TRUE(rate->waitOutput(" B/s")) << rate->output();
  rate->signal(SIGINT);
  EXPECT_EQ(rate->wait(), 0);
  // Only the owner publishes; only one's own names can be created.
  auto taken = flowctl({"pub", "guest.counter", "x"});
  EXPECT_EQ(taken.code, 7);
  EXPECT_TRUE(has(taken, "only its owner")) << taken.out;
  auto theirs = flowctl({"pub", "bob.counter", "x"});
  EXPECT_EQ(theirs.code, 7);
  EXPECT_TRUE(has(theirs, "is not yours")) << theirs.out;
  auto service = flowctl({"echo", "guest.adder"});
  EXPECT_EQ(service.code, 1);
  EXPECT_TRUE(has(service, "not a streaming channel")) << service.out;
}

// A subscriber on a direct path (physical mode): graph draws its edge dashed, info says so.
TEST_F(Flowctl, GraphAndInfoShowWhichSubscriberTakesAPath) {
  auto camera = satellite("camera");
  ChannelSpec spec{.name = "frames"};
  spec.physical = PhysicalOptions{.direct = true};
  ASSERT_TRUE(camera->on([&](Satellite& s) { return s.addChannel(spec); }));
  auto viewer = satellite("viewer");
  viewer->on([](Satellite& x) {
    x.usePaths("guest.frames", kPathDirect);
    x.subscribe("guest.frames");
  });
  auto plain = satellite("plain");
  plain->on([](Satellite& x) { x.subscribe("guest.frames"); });
  int i = 0;
  ASSERT_TRUE(eventually([&] {
    camera->on([&](Satellite& s) { (void)s.publish("frames", "f" + std::to_string(i++)); });
    return viewer->on([](Satellite& s) { return s.pathStats().path_messages; }) > 0;
  }));
  // hub.inspect answers with the last second's statistics.
  Ran graph, info;
  EXPECT_TRUE(eventually([&] {
    graph = flowctl({"graph"});
    info = flowctl({"info", "guest.frames"});
    return has(graph, "[style=dashed, label=\"direct\"]") &&
           has(info, "guest/viewer (satellite) by a direct path");
  })) << graph.out
      << info.out;
  EXPECT_TRUE(has(info, "guest/plain (satellite)\n")) << info.out;
}

// The hub's statistics (hub.stats, hub.inspect) through top, info, graph, and a channel's rate
// and bandwidth measured by hz and bw.
TEST_F(Flowctl, StatisticsTopInfoGraphHzAndBw) {
  auto o = owner();
  auto viewer = satellite("viewer");
  viewer->on([](Satellite& x) { x.subscribe("guest.counter"); });
  ASSERT_TRUE(eventually([&] { return o->events.count("start:guest.counter") == 1; }));
  for (int i = 0; i < 40; ++i) {
    o->on([](Satellite& x) { (void)x.publish("counter", "tick"); });
  }
  for (int i = 0; i < 3; ++i) EXPECT_EQ(flowctl({"call", "guest.adder", "add", "[1]"}).code, 0);
  // The statistics of a second that saw all of it (hub.inspect answers the last second's).
  Variant stats;
  const auto row = [&](const std::string& name) -> const Variant* {
    for (const Variant& c : *stats.find("channels")->asList()) {
      if (*c.find("name")->asString() == name) return &c;
    }
    return nullptr;
  };
  ASSERT_TRUE(eventually([&] {
    auto r = flowctl({"--json", "top", "--once"});
    if (r.code != 0) return false;
    auto v = flow::variantFromJsonText(r.out);
    if (!v) return false;
    stats = *v;
    const Variant* c = row("guest.counter");
    const Variant* a = row("guest.adder");
    return c != nullptr && a != nullptr && c->find("messages")->asInt64() == 40 &&
           a->find("messages")->asInt64() == 3;
  }));
  const Variant& counter = *row("guest.counter");
  EXPECT_EQ(counter.find("bytes")->asInt64(), 160);
  EXPECT_EQ(counter.find("subscribers")->asInt64(), 1);
  EXPECT_EQ(*counter.find("owner")->asString(), "guest/owner");
  EXPECT_EQ(*row("guest.adder")->find("kind")->asString(), "service");
  EXPECT_NE(row("hub.stats"), nullptr);

  auto top = flowctl({"top", "--once", "--sort", "name"});
  EXPECT_EQ(top.code, 0) << top.out;
  EXPECT_TRUE(has(top, "CHANNEL")) << top.out;
  EXPECT_TRUE(has(top, "guest.counter")) << top.out;
  EXPECT_EQ(flowctl({"top", "--sort", "colour"}).code, 2);

  auto info = flowctl({"info", "guest.counter"});
  EXPECT_EQ(info.code, 0) << info.out;
  EXPECT_TRUE(has(info, "owner        guest/owner")) << info.out;
  EXPECT_TRUE(has(info, "guest/viewer (satellite)")) << info.out;
  EXPECT_TRUE(has(info, "40 messages")) << info.out;
  EXPECT_TRUE(has(info, R"("unit":"ticks")")) << info.out;
  // Both windows: the last second, and the last ten (or its age, when it is younger).
  EXPECT_TRUE(has(info, "  rate         ")) << info.out;
  EXPECT_TRUE(has(info, "over the last 1.0 s\n")) << info.out;
  auto info_json = flow::variantFromJsonText(flowctl({"--json", "info", "guest.counter"}).out);
  ASSERT_TRUE(info_json);
  for (const char* key : {"hz", "hz_10s", "bytes_per_s_10s", "age_s"}) {
    EXPECT_NE(info_json->find(key), nullptr) << key;
  }
  EXPECT_EQ(flowctl({"info", "guest.nothing"}).code, 5);

  auto graph = flowctl({"graph"});
  EXPECT_EQ(graph.code, 0) << graph.out;
  EXPECT_TRUE(has(graph, "digraph")) << graph.out;
  EXPECT_TRUE(has(graph, "label=\"guest/owner (satellite)\"")) << graph.out;
  EXPECT_TRUE(has(graph, "label=\"guest/viewer (satellite)\"")) << graph.out;
  EXPECT_TRUE(has(graph, "-> \"c:guest.counter\";")) << graph.out;
  EXPECT_TRUE(has(graph, "\"c:guest.counter\" -> ")) << graph.out;
  EXPECT_FALSE(has(graph, "hub.stats")) << graph.out;
  EXPECT_TRUE(has(flowctl({"graph", "--all"}), "hub.stats"));

  // hz and bw, measured here on what a publisher sends at 20 Hz.
  auto pub = background({"pub", "guest.beat", "12345", "--rate", "20", "--repeat", "200"});
  auto hz = flowctl({"--json", "hz", "guest.beat", "--count", "3"});
  EXPECT_EQ(hz.code, 0) << hz.out;
  const auto last_line = [](const std::string& out) {
    const size_t end = out.find_last_not_of('\n');
    return out.substr(out.rfind('\n', end) + 1, end - out.rfind('\n', end));
  };
  auto h = flow::variantFromJsonText(last_line(hz.out));
  ASSERT_TRUE(h) << hz.out;
  EXPECT_GT(*h->find("hz")->asDouble(), 5.0) << hz.out;  // 20 Hz, give or take a busy machine
  EXPECT_LT(*h->find("hz")->asDouble(), 80.0) << hz.out;
  auto bw = flowctl({"--json", "bw", "guest.beat", "--count", "1"});
  EXPECT_EQ(bw.code, 0) << bw.out;
  auto b = flow::variantFromJsonText(last_line(bw.out));
  ASSERT_TRUE(b) << bw.out;
  EXPECT_EQ(b->find("mean_bytes")->asDouble(), 5.0) << bw.out;
  EXPECT_EQ(b->find("max_bytes")->asDouble(), 5.0) << bw.out;
  pub->signal(SIGINT);
  EXPECT_EQ(pub->wait(), 0);
}

TEST_F(Flowctl, PubGivesTheChannelItCreatesItsProperties) {
  auto bad = flowctl({"pub", "p", "x", "--props", "[1]"});
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_TRUE(has(bad, "--props: a JSON object")) << bad.out;
  auto pub = background(
      {"pub", "guest.p", "x", "--rate", "20", "--props", R"({"encoding":"bgr8","width":8})"});
  Ran info;
  EXPECT_TRUE(eventually([&] {
    info = flowctl({"info", "guest.p"});
    return has(info, R"("encoding":"bgr8")") && has(info, R"("width":8)");
  })) << info.out;
  pub->signal(SIGINT);
  EXPECT_EQ(pub->wait(), 0);
}

TEST_F(Flowctl, PubAndEchoRos2MessagesAsJson) {
  // JSON published as the CDR of a shipped ROS 2 type: the channel says cdr and carries the
  // type's ros2msg schema; echo reads it back as JSON through that schema.
  auto echo = background({"--json", "echo", "guest.cmd_vel", "--wait", "--count", "1"});
  auto pub = flowctl({"pub", "cmd_vel", R"({"linear":{"x":0.25},"angular":{"z":-1}})",
                      "--ros2-type", "geometry_msgs/msg/Twist", "--wait-ms", "5000"});
  EXPECT_EQ(pub.code, 0) << pub.out;
  EXPECT_TRUE(has(pub, "published 1 message (52 bytes)")) << pub.out;
  EXPECT_EQ(echo->wait(), 0) << echo->output();
  EXPECT_EQ(echo->output(),
            R"({"bytes":52,"channel":"guest.cmd_vel","data":{"angular":{"x":0.0,"y":0.0,"z":-1.0},)"
            R"("linear":{"x":0.25,"y":0.0,"z":0.0}}})"
            "\n");
  auto typed = background({"pub", "guest.scan", R"({"ranges":[1.5,2]})", "--ros2-type",
                           "sensor_msgs/LaserScan", "--rate", "20"});
  Ran info;
  EXPECT_TRUE(eventually([&] {
    info = flowctl({"info", "guest.scan"});
    return has(info, "cdr") && has(info, "sensor_msgs/msg/LaserScan") && has(info, "ros2msg");
  })) << info.out;
  auto scan = flowctl({"echo", "guest.scan", "--count", "1"});
  EXPECT_TRUE(has(scan, R"("ranges":[1.5,2.0])")) << scan.out;
  typed->signal(SIGINT);
  EXPECT_EQ(typed->wait(), 0);
  // A user's interface package, and what is refused before anything is published.
  std::filesystem::create_directories(dir_.path() / "msgs/lab_msgs/msg");
  std::ofstream(dir_.path() / "msgs/lab_msgs/msg/Gripper.msg") << "float32 width\nbool closed\n";
  auto lab = background({"echo", "guest.grip", "--wait", "--count", "1"});
  EXPECT_EQ(flowctl({"pub", "grip", R"({"closed":true})", "--ros2-type", "lab_msgs/msg/Gripper",
                     "--definitions", (dir_.path() / "msgs").string(), "--wait-ms", "5000"})
                .code,
            0);
  EXPECT_EQ(lab->wait(), 0);
  EXPECT_EQ(lab->output(), "{\"closed\":true,\"width\":0.0}\n");
  const std::pair<std::vector<std::string>, const char*> refused[] = {
      {{"pub", "x", "{}", "--ros2-type", "geometry_msgs/msg/Twst"},
       "no definition of geometry_msgs/msg/Twst"},
      {{"pub", "x", R"({"linaer":{}})", "--ros2-type", "geometry_msgs/msg/Twist"},
       "geometry_msgs/msg/Twist.linaer: no such field in geometry_msgs/msg/Twist"},
      {{"pub", "x", "{}", "--ros2-type", "geometry_msgs/msg/Twist", "--variant"},
       "--ros2-type gives the channel its type"},
  };
  for (const auto& [args, why] : refused) {
    auto r = flowctl(args);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(has(r, why)) << r.out;
  }
}

TEST_F(Flowctl, CallsServices) {
  auto o = owner();
  auto ok = flowctl({"call", "guest.adder", "add", "[41]"});
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_EQ(ok.out, "42\n");
  auto timeout = flowctl({"call", "guest.adder", "ignored", "null", "--timeout-ms", "200"});
  EXPECT_EQ(timeout.code, 6) << timeout.out;
  EXPECT_TRUE(has(timeout, "did not answer within 200 ms")) << timeout.out;
  EXPECT_EQ(flowctl({"call", "guest.nope", "add", "[1]"}).code, 5);
  EXPECT_EQ(flowctl({"call", "guest.adder", "add", "not json"}).code, 2);
  EXPECT_EQ(flowctl({"call", "guest.counter", "add", "[1]"}).code, 1);
}

// An answer that says the call failed is printed, and the exit code says so (8).
TEST_F(Flowctl, CallExitsNonZeroWhenTheAnswerSaysItFailed) {
  auto s = satellite("refuser");
  s->on([](Satellite& x) {
    ASSERT_TRUE(x.addChannel({.name = "arm", .kind = flow::ChannelKind::service}));
    x.serviceRequest.connect(&x, [&x](const Request& r) {
      if (r.command == "ok") (void)x.respond(r, Variant::Map{{"ok", true}});
      if (r.command == "no") (void)x.respond(r, Variant::Map{{"ok", false}, {"error", "stalled"}});
      if (r.command == "bad") (void)x.respond(r, Variant::Map{{"error", "unknown command"}});
      if (r.command == "bare") (void)x.respond(r, Variant::Map{{"ok", false}});
    });
  });
  ASSERT_TRUE(eventually([&] { return s->events.count("ready:") == 1; }));
  auto ok = flowctl({"call", "guest.arm", "ok"});
  EXPECT_EQ(ok.code, 0) << ok.out;
  auto no = flowctl({"call", "guest.arm", "no"});
  EXPECT_EQ(no.code, 8) << no.out;
  EXPECT_TRUE(has(no, "{\"error\":\"stalled\",\"ok\":false}\n")) << no.out;
  EXPECT_TRUE(has(no, "flowctl: guest.arm: stalled")) << no.out;
  auto bad = flowctl({"call", "guest.arm", "bad"});
  EXPECT_EQ(bad.code, 8) << bad.out;
  EXPECT_TRUE(has(bad, "unknown command")) << bad.out;
  EXPECT_EQ(flowctl({"call", "guest.arm", "bare"}).code, 8);
}

TEST_F(Flowctl, Databases) {
  EXPECT_EQ(flowctl({"db", "set", "speed", "1.5"}).code, 0);
  EXPECT_EQ(flowctl({"db", "set", "name", "\"nao\""}).code, 0);
  EXPECT_EQ(flowctl({"db", "get", "speed"}).out, "1.5\n");
  EXPECT_EQ(flowctl({"db", "ls"}).out, "name = \"nao\"\nspeed = 1.5\n");
  EXPECT_EQ(flowctl({"--json", "db", "ls"}).out, "{\"name\":\"nao\",\"speed\":1.5}\n");
  EXPECT_EQ(flowctl({"db", "del", "speed"}).code, 0);
  auto gone = flowctl({"db", "get", "speed"});
  EXPECT_EQ(gone.code, 5);
  EXPECT_TRUE(has(gone, "no variable \"speed\"")) << gone.out;
  EXPECT_EQ(flowctl({"db", "set", "x", "unquoted"}).code, 2);
  EXPECT_EQ(flowctl({"db", "save"}).code, 0);
  EXPECT_TRUE(has(flowctl({"db", "databases"}), "guest\n"));
  EXPECT_EQ(flowctl({"db", "get", "k", "--db", "no-such-db"}).code, 5);
  auto o = owner();
  EXPECT_EQ(flowctl({"db", "get", "unit", "--db", "guest.counter"}).out, "\"ticks\"\n");
  auto denied = flowctl({"db", "set", "unit", "1", "--db", "guest.counter"});
  EXPECT_EQ(denied.code, 7) << denied.out;
}

TEST_F(Flowctl, BlobFiles) {
  const auto local = dir_.path() / "map.pgm";
  std::ofstream(local, std::ios::binary) << std::string(300000, 'm');
  // put creates the caller's blob channel; ls, get, mkdir, rmdir and rm work on it.
  auto put = flowctl({"blob", "put", "maps", local.string(), "floor1/map.pgm"});
  ASSERT_EQ(put.code, 0) << put.out;
  // What was stored, with the version the channel lists for it (a version is an opaque number).
  const std::string said =
      "stored " + local.string() + " as guest.maps:floor1/map.pgm, 300000 bytes, version ";
  ASSERT_EQ(put.out.substr(0, said.size()), said) << put.out;
  auto listed = flowctl({"--json", "blob", "ls", "maps", "floor1"});
  EXPECT_TRUE(has(
      listed, "\"version\":" + put.out.substr(said.size(), put.out.size() - said.size() - 1) + "}"))
      << put.out << listed.out;
  auto again = flowctl({"--json", "blob", "put", "maps", local.string(), "floor1/map.pgm"});
  EXPECT_TRUE(has(again,
                  "{\"channel\":\"guest.maps\",\"path\":\"floor1/map.pgm\",\"size\":300000,"
                  "\"version\":"))
      << again.out;
  EXPECT_TRUE(has(flowctl({"ls"}), "guest.maps"));
  auto ls = flowctl({"blob", "ls", "guest.maps"});
  EXPECT_TRUE(has(ls, "floor1/")) << ls.out;
  ls = flowctl({"--json", "blob", "ls", "maps", "floor1"});
  EXPECT_TRUE(has(ls, "\"name\":\"map.pgm\"")) << ls.out;
  EXPECT_TRUE(has(ls, "\"size\":300000")) << ls.out;
  const auto back = dir_.path() / "back.pgm";
  EXPECT_EQ(flowctl({"blob", "get", "maps", "floor1/map.pgm", back.string()}).code, 0);
  std::ifstream in(back, std::ios::binary);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), std::string(300000, 'm'));
  EXPECT_EQ(flowctl({"blob", "get", "maps", "floor1/map.pgm", "-"}).out, std::string(300000, 'm'));
  EXPECT_EQ(flowctl({"blob", "mkdir", "maps", "floor2"}).code, 0);
  EXPECT_EQ(flowctl({"blob", "rmdir", "maps", "floor2"}).code, 0);
  // Errors and their exit codes.
  EXPECT_EQ(flowctl({"blob", "get", "maps", "no/such/file", back.string()}).code, 5);
  EXPECT_EQ(flowctl({"blob", "ls", "nobody.maps"}).code, 5);
  EXPECT_EQ(flowctl({"blob", "put", "nobody.maps", local.string(), "x"}).code, 5);
  auto bad = flowctl({"blob", "get", "maps", "../../users.json", back.string()});
  EXPECT_EQ(bad.code, 1);
  EXPECT_TRUE(has(bad, "bad path")) << bad.out;
  EXPECT_EQ(flowctl({"blob", "rm", "maps", "floor1"}).code, 1);  // a directory: rmdir
  EXPECT_EQ(flowctl({"blob", "rm", "maps", "floor1/map.pgm"}).code, 0);
  EXPECT_EQ(flowctl({"blob", "rmdir", "maps", "floor1"}).code, 0);
  EXPECT_EQ(flowctl({"blob", "get", "maps"}).code, 2);
  EXPECT_EQ(flowctl({"blob", "copy", "maps", "a"}).code, 2);
}

// udp: addresses (docs/flow-protocol.md, "Addresses"): the key from a file, never the command
// line; pub runs on the flow alone, the synchronous commands are refused with the reason.
class FlowctlOverUdp : public Flowctl {
 protected:
  void SetUp() override { startUdpHub(); }
};

TEST_F(FlowctlOverUdp, PubOverUdpAndSyncCommandsRefused) {
  const fs::path key = dir_.path() / "alice.key";
  std::ofstream(key) << udp_key_hex_ << "\n";
  auto sub = satellite("sub");
  sub->on([](Satellite& s) { s.subscribe("alice.greeting"); });
  const std::vector<std::string> env = {"ROBOT_ADDRESS=" + udpAddress(), "ROBOT_USER=alice"};
  auto pub = flowctl(
      {"--udp-key-file", key.string(), "pub", "greeting", "hello", "--wait-ms", "5000"}, {}, env);
  EXPECT_EQ(pub.code, 0) << pub.out << hubLog();
  EXPECT_TRUE(has(pub, "published 1 message (5 bytes) on alice.greeting")) << pub.out;
  EXPECT_TRUE(eventually([&] { return sub->events.count("data:alice.greeting:hello") == 1; }))
      << sub->events.dump() << hubLog();
  auto ls = flowctl({"--udp-key-file", key.string(), "ls"}, {}, env);
  EXPECT_EQ(ls.code, 1) << ls.out;
  EXPECT_TRUE(has(ls, "a udp: address carries one session, the flow")) << ls.out;
  auto bad =
      flowctl({"--udp-key-file", (dir_.path() / "none.key").string(), "pub", "x", "y"}, {}, env);
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_TRUE(has(bad, "--udp-key-file: UDP key file")) << bad.out;
}

}  // namespace
}  // namespace skr::sat::test
