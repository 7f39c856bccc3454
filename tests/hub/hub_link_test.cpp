// SPDX-License-Identifier: Apache-2.0
// Hub links (docs/hub-links.md): hubs started as processes on one machine, each with its own app
// name, socket and data directory; satellites of one use the channels of another by name.
#include <chrono>
#include <cmath>
#include <set>
#include <sstream>
#include <thread>

#include "named_hub.h"

namespace skr::sat::test {
namespace {

using flow::ErrorCode;
using flow::Variant;

bool hasChannel(SatOnThread& s, const std::string& name) {
  return s.on([&](Satellite& sat) { return sat.channel(name) != nullptr; });
}

// The channels a satellite sees, but every hub's own statistics (hub.stats, hub.inspect, and
// "<hub>/hub.*" across links).
size_t userChannels(Satellite& sat) {
  size_t n = 0;
  for (const auto& c : sat.channels()) {
    const size_t slash = c.name.rfind('/');
    if (c.name.compare(slash == std::string::npos ? 0 : slash + 1, 4, "hub.") != 0) ++n;
  }
  return n;
}

// A file of 9 MiB, more than two of the hub's 4 MiB chunks, that no two chunks repeat.
std::string mapFile() {
  std::string map(9u << 20, '\0');
  for (size_t i = 0; i < map.size(); ++i) map[i] = char((i * 7919u) >> 5);
  return map;
}

// `owner`'s blob channel "maps" with "floor/map.pgm" (mapFile) and "notes.txt": its id.
Result<uint16_t> makeMaps(SatOnThread& owner) {
  return owner.on([](Satellite& s) -> Result<uint16_t> {
    auto c = s.syncClient();
    if (!c) return c.error();
    auto ch = (*c)->createBlobChannel("maps");
    if (!ch) return ch.error();
    if (auto r = (*c)->blobPut(ch->id, "floor/map.pgm", mapFile()); !r) return r.error();
    if (auto r = (*c)->blobPut(ch->id, "notes.txt", "kitchen"); !r) return r.error();
    return ch->id;
  });
}

class HubLinks : public ::testing::Test {
 protected:
  // B, and A linked to it.
  void SetUp() override {
    b = std::make_unique<NamedHub>("bee");
    ASSERT_TRUE(b->start()) << b->hub->log();
    a = std::make_unique<NamedHub>("ay");
    ASSERT_TRUE(a->link(*b).start()) << a->hub->log();
    ASSERT_TRUE(a->hub->waitLog("HUB-LINK-UP")) << a->hub->log();
  }
  [[nodiscard]] std::string logs() const {
    return "--- A\n" + a->hub->log() + "--- B\n" + b->hub->log();
  }
  std::unique_ptr<NamedHub> b, a;
};

TEST_F(HubLinks, ARemoteChannelIsSubscribedOnDemandAndItsDataCrossesOnce) {
  auto owner = b->satellite("camera");
  ASSERT_TRUE(owner->on([](Satellite& s) {
    return s.addChannel(
        {.name = "counter", .mime = "text/plain", .props = Variant::Map{{"unit", "ticks"}}});
  }));
  auto s1 = a->satellite("viewer1");
  auto s2 = a->satellite("viewer2");
  ASSERT_TRUE(eventually([&] { return hasChannel(*s1, "bee/guest.counter"); })) << logs();
  const ChannelInfo info = s1->on([](Satellite& s) { return *s.channel("bee/guest.counter"); });
  EXPECT_EQ(info.owner, "bee/guest");
  EXPECT_EQ(info.mime, "text/plain");
  EXPECT_EQ(*info.props.find("unit"), Variant("ticks"));
  Child ls({FLOWCTL_BIN, "--address", a->hub->address(), "ls"}, {}, a->dir.path() / "ls.out");
  ASSERT_EQ(ls.wait(), 0) << ls.output();
  EXPECT_NE(ls.output().find(" bee bee/guest.counter "), std::string::npos) << ls.output();

  // Nobody on A wants it: the camera on B is not asked to publish.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(owner->events.count("start:guest.counter"), 0u);
  s1->on([](Satellite& s) { s.subscribe("bee/guest.counter"); });
  s2->on([](Satellite& s) { s.subscribe("bee/guest.counter"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.counter") == 1; }))
      << logs();
  ASSERT_TRUE(eventually([&] {
    return s1->events.count("subscribed:bee/guest.counter") == 1 &&
           s2->events.count("subscribed:bee/guest.counter") == 1;
  }));
  // "subscribed" says a SUBSCRIBE was sent: wait until hub A has both, or the first messages
  // relayed from B could reach A before viewer2's SUBSCRIBE does (seen under asan).
  ASSERT_TRUE(eventually([&] {
    return s1->on([](Satellite& s) {
      return s.syncClient().value()->channel("bee/guest.counter").value().subscribers;
    }) == 2u;
  })) << logs();
  for (int i = 0; i < 20; ++i) {
    ASSERT_TRUE(owner->on([i](Satellite& s) { return s.publish("counter", std::to_string(i)); }));
  }
  ASSERT_TRUE(eventually([&] {
    return s1->events.count("data:bee/guest.counter:") == 20 &&
           s2->events.count("data:bee/guest.counter:") == 20;
  })) << "viewer1:\n"
      << s1->events.dump() << "viewer2:\n"
      << s2->events.dump() << logs();
  const auto got = s1->events.with("data:bee/guest.counter:");
  for (int i = 0; i < 20; ++i) EXPECT_EQ(got[i], std::to_string(i));
  // The link is one subscriber of B's channel, whatever the number behind it.
  const auto on_b = owner->on(
      [](Satellite& s) { return s.syncClient().value()->channel("guest.counter").value(); });
  EXPECT_EQ(on_b.subscribers, 1u);

  // The last subscriber on A leaves: the owner on B hears of it.
  s1->on([](Satellite& s) { s.unsubscribe("bee/guest.counter"); });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(owner->events.count("stop:guest.counter"), 0u);
  s2->on([](Satellite& s) { s.unsubscribe("bee/guest.counter"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("stop:guest.counter") == 1; })) << logs();

  // Properties follow, and a removed channel goes on A too.
  ASSERT_TRUE(owner->on([](Satellite& s) {
    return s.setChannelProperties("counter", Variant::Map{{"unit", "frames"}});
  }));
  ASSERT_TRUE(eventually([&] {
    return s1->on([](Satellite& s) {
      const ChannelInfo* c = s.channel("bee/guest.counter");
      return c != nullptr && c->props.find("unit") != nullptr &&
             *c->props.find("unit") == Variant("frames");
    });
  })) << s1->events.dump();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.removeChannel("counter"); }));
  ASSERT_TRUE(eventually([&] { return s1->events.count("removed:bee/guest.counter") == 1; }));
}

// What the connections of `hub` follow (their flow databases' sync_following), joined.
std::string followedOn(NamedHub& hub, const std::string& tag) {
  Child dbs({FLOWCTL_BIN, "--address", hub.hub->address(), "db", "databases"}, {},
            hub.dir.path() / (tag + "-dbs.out"));
  if (dbs.wait() != 0) return "flowctl db databases failed: " + dbs.output();
  std::istringstream names(dbs.output());
  std::string name, all;
  while (std::getline(names, name)) {
    if (!name.starts_with("_flow.")) continue;
    Child get(
        {FLOWCTL_BIN, "--address", hub.hub->address(), "db", "get", "--db", name, "sync_following"},
        {}, hub.dir.path() / (tag + "-get.out"));
    if (get.wait() != 0) continue;
    std::string v = get.output();
    while (!v.empty() && (v.back() == '\n' || v.back() == '"')) v.pop_back();
    if (!v.empty() && v.front() == '"') v.erase(0, 1);
    if (!v.empty()) all += (all.empty() ? "" : ",") + v;
  }
  return all;
}

// Sync sources cross links (docs/hub-links.md): the far source is followed only while someone
// here follows its name, and each of its pulses is pulsed again here.
TEST_F(HubLinks, ASyncSourceIsFollowedAcrossTheLinkWhileSomeoneHereFollowsIt) {
  auto clock = b->satellite("clock");
  ASSERT_TRUE(clock->on([](Satellite& s) {
    return s.addChannel({.name = "tick", .kind = flow::ChannelKind::sync});
  }));
  auto follower = a->satellite("follower");
  ASSERT_TRUE(eventually([&] { return hasChannel(*follower, "bee/guest.tick"); })) << logs();
  EXPECT_EQ(follower->on([](Satellite& s) { return s.channel("bee/guest.tick")->kind; }),
            uint8_t(flow::ChannelKind::sync));
  EXPECT_EQ(followedOn(*b, "before"), "") << "nobody follows it on ay yet";
  follower->on([](Satellite& s) { s.follow("bee/guest.tick"); });
  ASSERT_TRUE(eventually([&] { return followedOn(*b, "during") == "guest.tick"; })) << logs();
  // Pulses until five arrived here (a busy machine may drop one for a target still busy, on
  // either hub: counted, never reordered).
  for (int i = 0; i < 200 && follower->events.count("pulse:bee/guest.tick:") < 5; ++i) {
    EXPECT_TRUE(clock->on([](Satellite& s) { return s.pulse("tick"); }));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const auto got = follower->events.with("pulse:bee/guest.tick:");
  ASSERT_GE(got.size(), 5u) << follower->events.dump() << logs();
  uint64_t last = 0;
  for (const std::string& e : got) {  // "<seq>:<dropped>"
    const uint64_t seq = std::stoull(e.substr(0, e.find(':')));
    EXPECT_GT(seq, last) << follower->events.dump();
    last = seq;
  }
  follower->on([](Satellite& s) { s.unfollow("bee/guest.tick"); });
  ASSERT_TRUE(eventually([&] { return followedOn(*b, "after").empty(); })) << logs();
}

TEST_F(HubLinks, RemoteServicesAnswerWithTheErrorsOfLocalOnes) {
  auto owner = b->satellite("service");
  ASSERT_TRUE(owner->on([](Satellite& s) {
    return s.addChannel({.name = "echo", .kind = flow::ChannelKind::service});
  }));
  bool answer = true;
  std::mutex m;
  owner->on([&](Satellite& s) {
    s.serviceRequest.connect(&s, [&s, &answer, &m](const Request& r) {
      std::lock_guard lock(m);
      if (answer) (void)s.respond(r, Variant::Map{{"command", r.command}, {"value", r.value}});
    });
  });
  auto caller = a->satellite("caller");
  ASSERT_TRUE(eventually([&] { return hasChannel(*caller, "bee/guest.echo"); })) << logs();

  // Asynchronous and synchronous calls.
  std::vector<Response> responses;
  std::mutex rm;
  const auto keep = [&](const Response& r) {
    std::lock_guard lock(rm);
    responses.push_back(r);
  };
  ASSERT_TRUE(caller->on([&](Satellite& s) { return s.request("bee/guest.echo", "hi", 7, keep); }));
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(rm);
    return responses.size() == 1;
  }));
  EXPECT_TRUE(responses[0].ok());
  EXPECT_EQ(*responses[0].value.find("value"), Variant(int64_t{7}));
  auto called = caller->on([](Satellite& s) { return s.call("bee/guest.echo", "sync", 8); });
  ASSERT_TRUE(called) << called.error().message;
  EXPECT_EQ(*called->find("command"), Variant("sync"));

  // The owner does not answer in time: timeout, as on one hub.
  {
    std::lock_guard lock(m);
    answer = false;
  }
  ASSERT_TRUE(
      caller->on([&](Satellite& s) { return s.request("bee/guest.echo", "late", 1, keep, 300); }));
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(rm);
    return responses.size() == 2;
  }));
  EXPECT_EQ(responses[1].error, ErrorCode::timeout) << flow::variantToJsonText(responses[1].value);

  // The owner goes while a request waits: owner_gone.
  ASSERT_TRUE(caller->on([&](Satellite& s) { return s.request("bee/guest.echo", "x", 1, keep); }));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  owner.reset();
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(rm);
    return responses.size() == 3;
  })) << logs();
  EXPECT_EQ(responses[2].error, ErrorCode::owner_gone)
      << flow::variantToJsonText(responses[2].value);
}

TEST_F(HubLinks, ADroppedLinkRemovesTheChannelsAndComesBackWithTheSubscriptions) {
  auto owner = b->satellite("camera");
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.addChannel({.name = "counter"}); }));
  auto viewer = a->satellite("viewer");
  viewer->on([](Satellite& s) { s.subscribe("bee/guest.counter"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.counter") == 1; }))
      << logs();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.publish("counter", "before"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:bee/guest.counter:before"); }));

  ASSERT_EQ(b->hub->stop(), 0);
  ASSERT_TRUE(eventually([&] { return viewer->events.count("removed:bee/guest.counter") == 1; }))
      << logs();
  EXPECT_TRUE(viewer->connected());  // its own hub stays

  ASSERT_TRUE(b->start());
  // The owner comes back by itself, the link too, and the viewer's subscription by name.
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.counter") == 2; }, 20000))
      << logs() << owner->events.dump();
  ASSERT_TRUE(eventually([&] { return viewer->events.count("subscribed:bee/guest.counter") == 2; }))
      << viewer->events.dump();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.publish("counter", "after"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:bee/guest.counter:after"); }))
      << viewer->events.dump();
  EXPECT_EQ(viewer->events.count("data:bee/guest.counter:before"), 1u);
}

TEST(HubLinkChain, TheFarHubsChannelsKeepTheirOwnHubName) {
  // A -> B -> C.
  auto c = std::make_unique<NamedHub>("sea");
  ASSERT_TRUE(c->start());
  auto b = std::make_unique<NamedHub>("bee");
  ASSERT_TRUE(b->link(*c).start());
  auto a = std::make_unique<NamedHub>("ay");
  ASSERT_TRUE(a->link(*b).start());
  const auto logs = [&] {
    return "--- A\n" + a->hub->log() + "--- B\n" + b->hub->log() + "--- C\n" + c->hub->log();
  };

  auto owner = c->satellite("far");
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.addChannel({.name = "counter"}); }));
  auto viewer = a->satellite("viewer");
  ASSERT_TRUE(eventually([&] { return hasChannel(*viewer, "sea/guest.counter"); }, 20000))
      << logs();
  EXPECT_FALSE(hasChannel(*viewer, "bee/sea/guest.counter"));
  viewer->on([](Satellite& s) { s.subscribe("sea/guest.counter"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.counter") == 1; }))
      << logs();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.publish("counter", "far"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:sea/guest.counter:far") == 1; }));

  // C's databases are read from A through B.
  ASSERT_TRUE(owner->on([](Satellite& s) {
    auto c = s.syncClient();
    return c && (*c)->createDatabase("maps") && (*c)->selectDatabase("maps") &&
           (*c)->set("floor", 2);
  }));
  EXPECT_EQ(viewer->on([](Satellite& s) { return s.get("floor", "sea/maps"); }).value(), Variant(2))
      << logs();

  // And its blob channels' files, through B, chunk by chunk.
  ASSERT_TRUE(makeMaps(*owner));
  ASSERT_TRUE(eventually([&] { return hasChannel(*viewer, "sea/guest.maps"); })) << logs();
  const auto map = viewer->on([](Satellite& s) {
    return s.syncClient().value()->blobGet(s.channel("sea/guest.maps")->id, "floor/map.pgm");
  });
  ASSERT_TRUE(map) << map.error().message << logs();
  EXPECT_TRUE(*map == mapFile());
}

// The link databases of two hubs that list each other: {hub's, the other's}.
std::pair<Variant::Map, Variant::Map> linkDbs(SatOnThread& on_a, SatOnThread& on_b) {
  const auto read = [](SatOnThread& s, const std::string& db) {
    return s.on([&](Satellite& sat) {
      auto all = sat.getAll(db);
      return all ? std::move(all).value() : Variant::Map{};
    });
  };
  return {read(on_a, "_link.bee"), read(on_b, "_link.ay")};
}

TEST(HubLinkPair, TwoHubsThatListEachOtherKeepOneConnectionUsedBothWays) {
  NamedHub a("ay");
  NamedHub b("bee");
  a.link(b);
  b.link(a);
  ASSERT_TRUE(a.start());
  ASSERT_TRUE(b.start());
  auto on_a = a.satellite("on-a");
  auto on_b = b.satellite("on-b");
  const auto logs = [&] { return "--- A\n" + a.hub->log() + "--- B\n" + b.hub->log(); };
  for (auto* s : {on_a.get(), on_b.get()}) {
    ASSERT_TRUE(s->on([](Satellite& sat) {
      return sat.addChannel({.name = "camera"}) &&
             sat.addChannel({.name = "echo", .kind = flow::ChannelKind::service});
    }));
    s->on([s](Satellite& sat) {
      sat.serviceRequest.connect(&sat, [&sat](const Request& r) {
        (void)sat.respond(r, Variant(sat.login().connection_id));
      });
    });
  }
  // One of them took the other's connection: its link says so, the other's is its own.
  const auto shared = [](const Variant::Map& m) {
    return m.contains("shared") && m.at("shared") == Variant(true);
  };
  ASSERT_TRUE(eventually(
      [&] {
        auto [la, lb] = linkDbs(*on_a, *on_b);
        return shared(la) != shared(lb) && (shared(la) ? lb : la).at("state") == Variant("up");
      },
      20000))
      << logs();
  ASSERT_TRUE(eventually([&] {
    return hasChannel(*on_a, "bee/guest.camera") && hasChannel(*on_a, "bee/guest.echo") &&
           hasChannel(*on_b, "ay/guest.camera") && hasChannel(*on_b, "ay/guest.echo");
  })) << logs();
  // Neither takes its own channels back from the other.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(hasChannel(*on_a, "ay/guest.camera"));
  EXPECT_FALSE(hasChannel(*on_b, "bee/guest.camera"));
  EXPECT_FALSE(hasChannel(*on_a, "bee/ay/guest.camera"));
  EXPECT_EQ(on_a->on([](Satellite& s) { return userChannels(s); }), 4u);
  EXPECT_EQ(on_b->on([](Satellite& s) { return userChannels(s); }), 4u);

  // Both ways: demand, data and service calls, over the one connection.
  for (auto [here, there, far] : {std::tuple{on_a.get(), on_b.get(), "bee/guest."},
                                  std::tuple{on_b.get(), on_a.get(), "ay/guest."}}) {
    const std::string camera = std::string(far) + "camera";
    EXPECT_EQ(there->events.count("start:guest.camera"), 0u);
    here->on([&](Satellite& s) { s.subscribe(camera); });
    ASSERT_TRUE(eventually([&] { return there->events.count("start:guest.camera") == 1; }))
        << logs();
    ASSERT_TRUE(eventually([&] { return here->events.count("subscribed:" + camera) == 1; }));
    ASSERT_TRUE(there->on([](Satellite& s) { return s.publish("camera", "frame"); }));
    ASSERT_TRUE(eventually([&] { return here->events.count("data:" + camera + ":frame") == 1; }))
        << logs();
    const auto answer = here->on(
        [&](Satellite& s) { return s.call(std::string(far) + "echo", "who", Variant(), 5000); });
    ASSERT_TRUE(answer) << answer.error().message << logs();
    EXPECT_EQ(*answer, Variant(there->on([](Satellite& s) { return s.login().connection_id; })));
    here->on([&](Satellite& s) { s.unsubscribe(camera); });
    ASSERT_TRUE(eventually([&] { return there->events.count("stop:guest.camera") == 1; }));
  }

  // The hub that dialled restarts: the link comes back, both ways, still one connection.
  auto [la, lb] = linkDbs(*on_a, *on_b);
  NamedHub& dialler = shared(la) ? b : a;
  auto& its_sat = shared(la) ? on_b : on_a;
  auto& other_sat = shared(la) ? on_a : on_b;
  const std::string other_prefix = shared(la) ? "ay/" : "bee/";
  const std::string its_prefix = shared(la) ? "bee/" : "ay/";
  ASSERT_EQ(dialler.hub->stop(), 0);
  ASSERT_TRUE(eventually([&] { return !hasChannel(*other_sat, its_prefix + "guest.echo"); }));
  ASSERT_TRUE(dialler.start());
  ASSERT_TRUE(eventually(
      [&] {
        return hasChannel(*other_sat, its_prefix + "guest.echo") &&
               hasChannel(*its_sat, other_prefix + "guest.echo");
      },
      20000))
      << logs();
  ASSERT_TRUE(eventually([&] {
    auto [na, nb] = linkDbs(*on_a, *on_b);
    return shared(na) != shared(nb);
  })) << logs();
}

TEST(HubLinkPair, OverOneConnectionEachHubShowsTheOtherWhatItsLinkAccountMayUse) {
  NamedHub a("ay");
  NamedHub b("bee");
  for (NamedHub* h : {&a, &b}) {
    h->account = "linker";
    h->rules = {{"subscribe", {"guest.open"}}, {"call", {"nothing"}}};
  }
  a.link(b);
  b.link(a);
  ASSERT_TRUE(a.start());
  ASSERT_TRUE(b.start());
  auto on_a = a.satellite("on-a");
  auto on_b = b.satellite("on-b");
  for (auto* s : {on_a.get(), on_b.get()}) {
    ASSERT_TRUE(s->on([](Satellite& sat) {
      return sat.addChannel({.name = "open"}) && sat.addChannel({.name = "secret"}) &&
             sat.addChannel({.name = "echo", .kind = flow::ChannelKind::service});
    }));
  }
  const auto logs = [&] { return "--- A\n" + a.hub->log() + "--- B\n" + b.hub->log(); };
  // The hub that dialled logs in as guest over there (every channel of the other comes); the
  // other sees of the dialler what the dialler's links[].account may use.
  ASSERT_TRUE(eventually(
      [&] {
        auto [la, lb] = linkDbs(*on_a, *on_b);
        return la.contains("shared") && lb.contains("shared") && la.at("shared") != lb.at("shared");
      },
      20000))
      << logs();
  auto [la, lb] = linkDbs(*on_a, *on_b);
  const bool a_dialled = lb.at("shared") == Variant(true);
  SatOnThread& dialler = a_dialled ? *on_a : *on_b;
  SatOnThread& dialled = a_dialled ? *on_b : *on_a;
  const std::string dialler_hub = a_dialled ? "ay/" : "bee/";
  const std::string dialled_hub = a_dialled ? "bee/" : "ay/";
  ASSERT_TRUE(eventually([&] {
    return hasChannel(dialled, dialler_hub + "guest.open") &&
           hasChannel(dialler, dialled_hub + "guest.secret") &&
           hasChannel(dialler, dialled_hub + "guest.echo");
  })) << logs();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(hasChannel(dialled, dialler_hub + "guest.secret"));
  EXPECT_FALSE(hasChannel(dialled, dialler_hub + "guest.echo"));
}

TEST(HubLinkRoutes, AShorterRouteReplacesALongerOneAndSubscribersFollow) {
  // C, B linked to C, and A linked to B and to C; A's direct link finds C only later (its
  // address is a symbolic link made once A shows C's channel through B).
  NamedHub c("sea"), b("bee"), a("ay");
  ASSERT_TRUE(c.start());
  ASSERT_TRUE(b.link(c).start());
  const fs::path later = a.dir.path() / "sea-later.sock";
  ASSERT_TRUE(a.link(b).link(c, "local:" + later.string()).start());
  const auto logs = [&] {
    return "--- A\n" + a.hub->log() + "--- B\n" + b.hub->log() + "--- C\n" + c.hub->log();
  };
  auto owner = c.satellite("owner");
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.addChannel({.name = "x"}); }));
  auto viewer = a.satellite("viewer");
  const auto route = [&] {
    return viewer->on([](Satellite& s) {
      const ChannelInfo* ch = s.channel("sea/guest.x");
      const Variant* r = ch != nullptr ? ch->props.find("hub_route") : nullptr;
      return r != nullptr && r->asList() != nullptr ? r->asList()->size() : size_t(0);
    });
  };
  ASSERT_TRUE(eventually([&] { return route() == 2; }, 20000)) << logs();  // sea, bee
  viewer->on([](Satellite& s) { s.subscribe("sea/guest.x"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.x") == 1; })) << logs();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.publish("x", "long"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:sea/guest.x:long") == 1; }));

  fs::create_symlink(c.dir.path() / "hub.sock", later);
  ASSERT_TRUE(eventually([&] { return route() == 1; }, 20000)) << logs();
  ASSERT_TRUE(a.hub->waitLog("HUB-ROUTE-SWITCH")) << logs();
  // The subscriber follows the channel to its new route; nothing comes twice.
  ASSERT_TRUE(eventually([&] { return viewer->events.count("subscribed:sea/guest.x") == 2; }))
      << viewer->events.dump();
  // The new route's subscription on C may still be on its way: publish until one arrives.
  int sent = 0;
  ASSERT_TRUE(eventually([&] {
    (void)owner->on([&](Satellite& s) { return s.publish("x", "short" + std::to_string(++sent)); });
    return viewer->events.count("data:sea/guest.x:short") > 0;
  })) << logs();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const auto got = viewer->events.with("data:sea/guest.x:");
  EXPECT_EQ(std::set<std::string>(got.begin(), got.end()).size(), got.size())
      << viewer->events.dump();
  EXPECT_EQ(got.front(), "long");
  EXPECT_EQ(viewer->on([](Satellite& s) { return userChannels(s); }), 1u);
}

TEST(HubLinkTriangle, ThreeHubsThatAllListEachOtherSeeEveryChannelOnceOverSharedLinks) {
  NamedHub a("ay"), b("bee"), c("sea");
  a.link(b).link(c);
  b.link(a).link(c);
  c.link(a).link(b);
  for (NamedHub* h : {&a, &b, &c}) ASSERT_TRUE(h->start());
  auto on_a = a.satellite("on-a");
  auto on_b = b.satellite("on-b");
  auto on_c = c.satellite("on-c");
  for (auto* s : {on_a.get(), on_b.get(), on_c.get()}) {
    ASSERT_TRUE(s->on([](Satellite& sat) { return sat.addChannel({.name = "x"}); }));
  }
  const auto logs = [&] {
    return "--- A\n" + a.hub->log() + "--- B\n" + b.hub->log() + "--- C\n" + c.hub->log();
  };
  ASSERT_TRUE(eventually(
      [&] {
        return hasChannel(*on_a, "bee/guest.x") && hasChannel(*on_a, "sea/guest.x") &&
               hasChannel(*on_b, "ay/guest.x") && hasChannel(*on_b, "sea/guest.x") &&
               hasChannel(*on_c, "ay/guest.x") && hasChannel(*on_c, "bee/guest.x");
      },
      20000))
      << logs();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  for (auto* s : {on_a.get(), on_b.get(), on_c.get()}) {
    EXPECT_EQ(s->on([](Satellite& sat) { return userChannels(sat); }), 3u) << logs();
  }
  on_a->on([](Satellite& s) { s.subscribe("sea/guest.x"); });
  ASSERT_TRUE(eventually([&] { return on_c->events.count("start:guest.x") == 1; })) << logs();
  ASSERT_TRUE(eventually([&] { return on_a->events.count("subscribed:sea/guest.x") == 1; }));
  ASSERT_TRUE(on_c->on([](Satellite& s) { return s.publish("x", "once"); }));
  ASSERT_TRUE(eventually([&] { return on_a->events.count("data:sea/guest.x:once") == 1; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(on_a->events.count("data:"), 1u);
}

TEST_F(HubLinks, TheLinkShowsItsStateRoundTripAndClockOffset) {
  auto viewer = a->satellite("viewer");
  // The link's database on A, written once a second.
  const auto link = [&]() {
    return viewer->on([](Satellite& s) {
      auto sync = s.syncClient();
      if (!sync || !(*sync)->selectDatabase("_link.bee")) return Variant::Map{};
      auto all = (*sync)->getAll();
      return all ? std::move(all).value() : Variant::Map{};
    });
  };
  ASSERT_TRUE(eventually([&] { return link().contains("round_trip_us"); })) << a->hub->log();
  Variant::Map m = link();
  EXPECT_EQ(m["state"], Variant("up"));
  EXPECT_EQ(m["hub"], Variant("bee"));
  const double rtt = m["round_trip_us"].asDouble().value_or(-1);
  const double offset = m["clock_offset_us"].asDouble().value_or(1e9);
  EXPECT_GT(rtt, 0);
  EXPECT_LT(rtt, 1e6);
  // One machine, one clock: the offset is within the round trip.
  EXPECT_LE(std::abs(offset), rtt);
  Child ls({FLOWCTL_BIN, "--address", a->hub->address(), "link", "ls"}, {},
           a->dir.path() / "link.out");
  ASSERT_EQ(ls.wait(), 0) << ls.output();
  EXPECT_NE(ls.output().find("bee "), std::string::npos) << ls.output();
  EXPECT_NE(ls.output().find(" up "), std::string::npos) << ls.output();

  // A satellite probes its own hub's clock the same way.
  std::vector<TimeSample> samples;
  std::mutex sm;
  viewer->on([&](Satellite& s) {
    s.timeSample.connect(&s, [&](const TimeSample& t) {
      std::lock_guard lock(sm);
      samples.push_back(t);
    });
  });
  ASSERT_TRUE(viewer->on([](Satellite& s) { return s.probeTime(); }));
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(sm);
    return samples.size() == 1;
  }));
  EXPECT_GE(samples[0].t2, samples[0].t1 - 1000000);
  EXPECT_GE(samples[0].t4, samples[0].t1);
  EXPECT_GT(samples[0].roundTripNs(), 0);

  ASSERT_EQ(b->hub->stop(), 0);
  ASSERT_TRUE(eventually([&] {
    const Variant::Map now = link();
    const Variant* state = now.contains("state") ? &now.at("state") : nullptr;
    return state != nullptr && state->asString() != nullptr &&
           state->asString()->starts_with("down");
  })) << a->hub->log();
}

TEST_F(HubLinks, AFarHubsDatabasesAreReadUnderItsNameAndNeverWritten) {
  auto writer = b->satellite("calibration");
  ASSERT_TRUE(writer->on([](Satellite& s) {
    auto c = s.syncClient();
    return c && (*c)->createDatabase("calib") && (*c)->selectDatabase("calib") &&
           (*c)->set("focal", 525.5) && (*c)->set("camera", "front");
  }));
  auto reader = a->satellite("reader");

  // Blocking reads over the synchronous connection, as for a database here.
  EXPECT_EQ(reader->on([](Satellite& s) { return s.get("focal", "bee/calib"); }).value(),
            Variant(525.5));
  const auto all = reader->on([](Satellite& s) { return s.getAll("bee/calib"); });
  ASSERT_TRUE(all) << all.error().message;
  EXPECT_EQ(all->size(), 2u);
  EXPECT_EQ(reader->on([](Satellite& s) { return s.keys("bee/calib"); }).value(),
            (std::vector<std::string>{"camera", "focal"}));
  const auto missing = reader->on([](Satellite& s) { return s.get("nothing", "bee/calib"); });
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::not_found);
  EXPECT_NE(missing.error().message.find("hub bee: "), std::string::npos);
  const auto no_hub = reader->on([](Satellite& s) { return s.get("focal", "sea/calib"); });
  ASSERT_FALSE(no_hub);
  EXPECT_EQ(no_hub.error().code, Errc::not_found);

  // Read here, written there.
  const auto written = reader->on([](Satellite& s) -> Result<void> {
    auto c = s.syncClient();
    if (!c) return c.error();
    if (auto r = (*c)->selectDatabase("bee/calib"); !r) return r;
    return (*c)->set("focal", 1.0);
  });
  ASSERT_FALSE(written);
  EXPECT_EQ(written.error().code, Errc::permission_denied) << written.error().message;

  // On the flow, without blocking.
  std::map<uint32_t, Response> answers;  // by tag: a read here answers before a far one
  std::mutex m;
  const auto keep = [&](const Response& r) {
    std::lock_guard lock(m);
    answers[r.tag] = r;
  };
  const auto tags = reader->on([&](Satellite& s) {
    return std::vector<uint32_t>{
        s.readDatabase("bee/calib", flow::msg::DbReadWhat::get, "camera", keep).value(),
        s.readDatabase("bee/nowhere", flow::msg::DbReadWhat::all, "", keep).value(),
        s.readDatabase("guest", flow::msg::DbReadWhat::keys, "", keep).value()};
  });
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(m);
    return answers.size() == 3;
  }));
  EXPECT_EQ(answers[tags[0]].value, Variant("front"));
  EXPECT_EQ(answers[tags[1]].error, ErrorCode::not_found);
  EXPECT_TRUE(answers[tags[2]].ok());  // a database here, the same way

  // The link goes: its hub's databases with it.
  ASSERT_EQ(b->hub->stop(), 0);
  ASSERT_TRUE(eventually([&] {
    auto r = reader->on([](Satellite& s) { return s.get("focal", "bee/calib"); });
    return !r && r.error().code == Errc::not_found;
  })) << a->hub->log();
}

TEST_F(HubLinks, AFarHubsBlobChannelIsReadThroughTheLinkAndWrittenOnlyThere) {
  auto owner = b->satellite("mapper");
  const auto maps = makeMaps(*owner);
  ASSERT_TRUE(maps) << maps.error().message;
  auto reader = a->satellite("planner");
  ASSERT_TRUE(eventually([&] { return hasChannel(*reader, "bee/guest.maps"); })) << logs();
  const ChannelInfo info = reader->on([](Satellite& s) { return *s.channel("bee/guest.maps"); });
  EXPECT_EQ(info.kind, uint8_t(flow::ChannelKind::blob));
  // Its changes are heard here by those who subscribe (the link subscribes there).
  reader->on([](Satellite& s) { s.subscribe("bee/guest.maps"); });
  ASSERT_TRUE(eventually([&] {
    return owner->on([](Satellite& s) {
      return s.syncClient().value()->channel("guest.maps").value().subscribers;
    }) == 1u;
  })) << logs();

  const auto sync = [&](auto fn) {
    return reader->on([&](Satellite& s) { return fn(*s.syncClient().value()); });
  };
  const auto list = sync([&](SyncClient& c) { return c.blobList(info.id, "floor"); });
  ASSERT_TRUE(list) << list.error().message;
  ASSERT_EQ(list->size(), 1u);
  EXPECT_EQ((*list)[0].name, "map.pgm");
  EXPECT_EQ((*list)[0].size, 9u << 20);
  const auto got = sync([&](SyncClient& c) { return c.blobGet(info.id, "floor/map.pgm"); });
  ASSERT_TRUE(got) << got.error().message << logs();
  EXPECT_TRUE(*got == mapFile());
  // The far hub's refusal, named; and nothing written here.
  const auto missing = sync([&](SyncClient& c) { return c.blobGet(info.id, "nowhere.bin"); });
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::not_found);
  EXPECT_NE(missing.error().message.find("hub bee: "), std::string::npos)
      << missing.error().message;
  const auto put = sync([&](SyncClient& c) { return c.blobPut(info.id, "mine.txt", "x"); });
  ASSERT_FALSE(put);
  EXPECT_EQ(put.error().code, Errc::permission_denied) << put.error().message;
  EXPECT_NE(put.error().message.find("another hub"), std::string::npos) << put.error().message;
  const auto removed = sync([&](SyncClient& c) { return c.blobRemove(info.id, "notes.txt"); });
  ASSERT_FALSE(removed);
  EXPECT_EQ(removed.error().code, Errc::permission_denied) << removed.error().message;
  EXPECT_FALSE(fs::exists(a->dir.path() / "data" / "blobs" / "bee"));

  // Written there: heard here, and its new version read through.
  ASSERT_TRUE(owner->on(
      [&](Satellite& s) { return s.syncClient().value()->blobPut(*maps, "notes.txt", "hall"); }));
  ASSERT_TRUE(eventually([&] {
    return reader->events.count("blob:bee/guest.maps:notes.txt:4") == 1;
  })) << reader->events.dump()
      << logs();
  const auto notes = sync([&](SyncClient& c) { return c.blobGet(info.id, "notes.txt"); });
  ASSERT_TRUE(notes) << notes.error().message;
  EXPECT_EQ(*notes, "hall");
}

TEST_F(HubLinks, AFarBlobReadCutWithTheLinkResumesFromItsOffset) {
  auto owner = b->satellite("mapper");
  ASSERT_TRUE(makeMaps(*owner));
  owner.reset();
  ConnectOptions o;
  o.address = Address::parse(a->hub->address()).value();
  auto c = SyncClient::connect(o);
  ASSERT_TRUE(c) << c.error().message;
  const auto farId = [&]() -> uint16_t {
    auto info = c->channel("bee/guest.maps");
    return info ? info->id : 0;
  };
  ASSERT_TRUE(eventually([&] { return farId() != 0; })) << logs();
  const std::string path = "floor/map.pgm";
  constexpr uint32_t kPiece = 1u << 20;
  auto first = c->blobRead(farId(), path, 0, 0, kPiece);
  ASSERT_TRUE(first) << first.error().message;
  const uint64_t version = first->version;
  std::string got = first->data;

  // The link is cut (hub B stops): the read fails with an error, and the connection here stays.
  const uint16_t before = farId();
  ASSERT_EQ(b->hub->stop(), 0);
  ASSERT_TRUE(eventually([&] { return farId() == 0; })) << logs();
  auto cut = c->blobRead(before, path, version, got.size(), kPiece);
  ASSERT_FALSE(cut);
  EXPECT_TRUE(cut.error().code == Errc::not_found || cut.error().code == Errc::io_error)
      << cut.error().message;
  EXPECT_TRUE(c->ping());

  // B is back with its files: the read goes on from its offset, of the same version.
  ASSERT_TRUE(b->hub->start()) << b->hub->log();
  ASSERT_TRUE(eventually([&] { return farId() != 0; }, 20000)) << logs();
  while (got.size() < first->total_size) {
    auto piece = c->blobRead(farId(), path, version, got.size(), kPiece);
    ASSERT_TRUE(piece) << piece.error().message << logs();
    ASSERT_EQ(piece->version, version);
    ASSERT_FALSE(piece->data.empty());
    got += piece->data;
  }
  EXPECT_TRUE(got == mapFile());
}

TEST(HubLinkBlobs, AFarBlobChannelIsReadOnlyByThoseWhoseRulesHereAllowItsName) {
  NamedHub b("bee");
  ASSERT_TRUE(b.start()) << b.hub->log();
  NamedHub a("ay");
  a.account = "viewer";  // may read guest.* here, not bee/guest.*
  a.rules = {{"subscribe", {"guest.*"}}};
  ASSERT_TRUE(a.link(b).start()) << a.hub->log();
  auto owner = b.satellite("mapper");
  ASSERT_TRUE(makeMaps(*owner));
  auto guest = a.satellite("planner");
  ASSERT_TRUE(eventually([&] { return hasChannel(*guest, "bee/guest.maps"); })) << a.hub->log();
  const uint16_t id = guest->on([](Satellite& s) { return s.channel("bee/guest.maps")->id; });
  ConnectOptions o;
  o.address = Address::parse(a.hub->tcpAddress()).value();
  o.user = "viewer";
  o.password = "s3cret-pass";
  auto viewer = SyncClient::connect(o);
  ASSERT_TRUE(viewer) << viewer.error().message;
  const auto refused = viewer->blobGet(id, "notes.txt");
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, Errc::permission_denied) << refused.error().message;
  const auto listed = viewer->blobList(id);
  ASSERT_FALSE(listed);
  EXPECT_EQ(listed.error().code, Errc::permission_denied);
  // The development account may, and the link's account over there may too.
  const auto read =
      guest->on([&](Satellite& s) { return s.syncClient().value()->blobGet(id, "notes.txt"); });
  ASSERT_TRUE(read) << read.error().message;
  EXPECT_EQ(*read, "kitchen");
}

TEST(HubLinkRoutes, AChannelReachedTwoWaysComesOnceAndSwitchesWhenItsRouteFails) {
  // A links to B1 and B2, both link to C, where the channel lives.
  NamedHub c("sea");
  NamedHub b1("bee1");
  NamedHub b2("bee2");
  NamedHub a("ay");
  b1.link(c);
  b2.link(c);
  a.link(b1).link(b2);
  ASSERT_TRUE(c.start());
  ASSERT_TRUE(b1.start());
  ASSERT_TRUE(b2.start());
  ASSERT_TRUE(a.start());
  auto owner = c.satellite("owner");
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.addChannel({.name = "seq"}); }));
  auto viewer = a.satellite("viewer");
  viewer->on([](Satellite& s) { s.subscribe("sea/guest.seq"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.seq") == 1; }))
      << a.hub->log() << b1.hub->log() << b2.hub->log();
  // One route: the hub it came through is the second of its route.
  const auto route = [&] {
    return viewer->on([](Satellite& s) {
      const ChannelInfo* c = s.channel("sea/guest.seq");
      const Variant* r = c != nullptr ? c->props.find("hub_route") : nullptr;
      return r != nullptr ? flow::variantToJsonText(*r) : std::string();
    });
  };
  const std::string first = route();
  ASSERT_TRUE(first == R"(["sea","bee1"])" || first == R"(["sea","bee2"])") << first;
  int seq = 0;
  const auto publish = [&](int n) {
    for (int i = 0; i < n; ++i) {
      const int k = seq++;
      ASSERT_TRUE(owner->on([k](Satellite& s) { return s.publish("seq", std::to_string(k)); }));
    }
  };
  publish(10);
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:sea/guest.seq:") == 10; }));

  // The route's middle hub goes: the channel comes back the other way, and the viewer's
  // subscription with it.
  NamedHub& via = first == R"(["sea","bee1"])" ? b1 : b2;
  ASSERT_EQ(via.hub->stop(), 0);
  ASSERT_TRUE(eventually([&] {
    const std::string now = route();
    return !now.empty() && now != first;
  })) << a.hub->log();
  ASSERT_TRUE(eventually([&] {
    return viewer->events.count("subscribed:sea/guest.seq") == 2 &&
           owner->events.count("start:guest.seq") == 2;
  })) << viewer->events.dump();
  publish(10);
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:sea/guest.seq:") == 20; }))
      << viewer->events.dump();
  // Nothing twice, nothing lost while a route stood.
  const auto got = viewer->events.with("data:sea/guest.seq:");
  for (int i = 0; i < 20; ++i) EXPECT_EQ(got[i], std::to_string(i));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(viewer->events.count("data:"), 20u);
}

TEST_F(HubLinks, ASatellitesReplicaMirrorsARemoteChannelWhileItsFlowLasts) {
  auto owner = b->satellite("camera");
  ASSERT_TRUE(owner->on([](Satellite& s) {
    return s.addChannel(
        {.name = "camera", .mime = "image/jpeg", .props = Variant::Map{{"fps", int64_t{15}}}});
  }));
  auto asker = a->satellite("asker");
  auto viewer = a->satellite("viewer");
  ASSERT_TRUE(eventually([&] { return hasChannel(*asker, "bee/guest.camera"); })) << logs();
  ASSERT_TRUE(asker->on([](Satellite& s) { return s.replicate("bee/guest.camera", "cam"); }));
  ASSERT_TRUE(eventually([&] { return hasChannel(*viewer, "guest.cam"); })) << logs();
  const ChannelInfo info = viewer->on([](Satellite& s) { return *s.channel("guest.cam"); });
  EXPECT_EQ(info.mime, "image/jpeg");
  EXPECT_EQ(*info.props.find("fps"), Variant(int64_t{15}));
  EXPECT_EQ(*info.props.find("replica_of"), Variant("bee/guest.camera"));
  // Nobody wants the replica yet: the camera does not run.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(owner->events.count("start:guest.camera"), 0u);

  viewer->on([](Satellite& s) { s.subscribe("guest.cam"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.camera") == 1; })) << logs();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.publish("camera", "f1"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:guest.cam:f1") == 1; }));
  ASSERT_TRUE(owner->on([](Satellite& s) {
    return s.setChannelProperties("camera", Variant::Map{{"fps", int64_t{30}}});
  }));
  ASSERT_TRUE(eventually([&] {
    return viewer->on([](Satellite& s) {
      const Variant* fps = s.channel("guest.cam")->props.find("fps");
      return fps != nullptr && *fps == Variant(int64_t{30});
    });
  }));
  // A second replica of the same name is refused; the asker leaving takes its replica along.
  ASSERT_TRUE(asker->on([](Satellite& s) { return s.replicate("bee/guest.camera", "cam"); }));
  ASSERT_TRUE(eventually([&] { return asker->events.count("error:a replica guest.cam exists"); }))
      << asker->events.dump();
  asker.reset();
  ASSERT_TRUE(eventually([&] { return viewer->events.count("removed:guest.cam") == 1; }));
  ASSERT_TRUE(eventually([&] { return owner->events.count("stop:guest.camera") == 1; }));
}

TEST(HubLinkReplicas, AReplicaOfTheConfigFollowsItsSourceAcrossLinkFailures) {
  NamedHub b("bee");
  NamedHub a("ay");
  a.extra = R"("replicas": [{"from": "bee/guest.camera", "as": "front"}], )";
  a.link(b);
  ASSERT_TRUE(b.start());
  ASSERT_TRUE(a.start());
  auto owner = b.satellite("camera");
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.addChannel({.name = "camera"}); }));
  auto viewer = a.satellite("viewer");
  viewer->on([](Satellite& s) { s.subscribe("hub.front"); });
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.camera") == 1; }))
      << a.hub->log();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.publish("camera", "one"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:hub.front:one") == 1; }));
  // The far hub restarts: the replica goes with its source and comes back with it.
  ASSERT_EQ(b.hub->stop(), 0);
  ASSERT_TRUE(eventually([&] { return viewer->events.count("removed:hub.front") == 1; }));
  ASSERT_TRUE(b.start());
  ASSERT_TRUE(eventually([&] { return owner->events.count("start:guest.camera") == 2; }, 20000))
      << a.hub->log();
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.publish("camera", "two"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:hub.front:two") == 1; }));
}

TEST(HubLinkStar, TenHubsAroundOneSeeEachOthersChannelsThroughTheCentre) {
  // The centre links to nine leaves, and each leaf to the centre.
  NamedHub centre("centre");
  std::vector<std::unique_ptr<NamedHub>> leaves;
  for (int i = 1; i <= 9; ++i) {
    leaves.push_back(std::make_unique<NamedHub>("leaf" + std::to_string(i)));
    centre.link(*leaves.back());
    leaves.back()->link(centre);
  }
  for (auto& leaf : leaves) ASSERT_TRUE(leaf->start());
  ASSERT_TRUE(centre.start());
  std::vector<std::unique_ptr<SatOnThread>> owners;
  for (auto& leaf : leaves) {
    owners.push_back(leaf->satellite("owner"));
    ASSERT_TRUE(owners.back()->on([](Satellite& s) { return s.addChannel({.name = "x"}); }));
  }
  auto viewer = leaves[0]->satellite("viewer");
  ASSERT_TRUE(eventually([&] {
    for (int i = 2; i <= 9; ++i) {
      if (!hasChannel(*viewer, "leaf" + std::to_string(i) + "/guest.x")) return false;
    }
    return hasChannel(*viewer, "guest.x");
  })) << centre.hub->log();
  // Its own channel never comes back, and each other leaf's comes once, through the centre.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(hasChannel(*viewer, "leaf1/guest.x"));
  const auto route = viewer->on([](Satellite& s) {
    return flow::variantToJsonText(*s.channel("leaf9/guest.x")->props.find("hub_route"));
  });
  EXPECT_EQ(route, R"(["leaf9","centre"])");
  viewer->on([](Satellite& s) { s.subscribe("leaf9/guest.x"); });
  ASSERT_TRUE(eventually([&] { return owners[8]->events.count("start:guest.x") == 1; }))
      << centre.hub->log();
  ASSERT_TRUE(owners[8]->on([](Satellite& s) { return s.publish("x", "from-9"); }));
  ASSERT_TRUE(eventually([&] { return viewer->events.count("data:leaf9/guest.x:from-9") == 1; }));
}

TEST_F(HubLinks, ASecondHubOfTheSameNameIsRefused) {
  auto twin = std::make_unique<NamedHub>("ay");
  ASSERT_TRUE(twin->link(*b).start());
  ASSERT_TRUE(twin->hub->waitLog("a hub named \"ay\" is linked already")) << twin->hub->log();
  EXPECT_TRUE(b->hub->waitLog("HUB-LINK-REFUSED"));
  // The first link is untouched.
  auto owner = b->satellite("owner");
  ASSERT_TRUE(owner->on([](Satellite& s) { return s.addChannel({.name = "still"}); }));
  auto viewer = a->satellite("viewer");
  ASSERT_TRUE(eventually([&] { return hasChannel(*viewer, "bee/guest.still"); })) << logs();
}

}  // namespace
}  // namespace skr::sat::test
