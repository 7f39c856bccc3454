// SPDX-License-Identifier: Apache-2.0
// Two or more C++ satellites through a real hub: channels, data, properties, services, databases.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <mutex>
#include <thread>

#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

using flow::Variant;

class Satellites : public SatTest {
 protected:
  void SetUp() override { startHub(); }
  // The hub's count, asked over a synchronous connection of the test's own.
  uint32_t subscribers(const std::string& name) {
    auto c = SyncClient::connect(options("probe").connection);
    auto info = c ? c->channel(name) : Result<ChannelInfo>(c.error());
    return info ? info->subscribers : 0;
  }
};

TEST_F(Satellites, PublishAndSubscribeByNameInBatches) {
  auto sub = satellite("sub");
  sub->on([](Satellite& s) { s.subscribe("guest.numbers"); });  // before it exists
  auto pub = satellite("pub");
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.addChannel({.name = "numbers"}); }));
  ASSERT_TRUE(eventually([&] { return pub->events.count("start:guest.numbers") == 1; }))
      << pub->events.dump();
  EXPECT_EQ(sub->events.count("subscribed:guest.numbers"), 1u);
  EXPECT_TRUE(sub->on([](Satellite& s) { return s.isSubscribed("guest.numbers"); }));

  // dataView sees each payload in place, before `data` copies it.
  std::vector<std::string> viewed;  // the sub's loop thread only, read once it is done
  sub->on([&](Satellite& s) {
    s.dataView.connect(
        &s, [&viewed](uint16_t, std::string_view payload) { viewed.emplace_back(payload); });
  });

  // 200 frames queued in one loop iteration leave in a few writes, not 200.
  const uint64_t writes_before = pub->on([](Satellite& s) { return s.stats().writes; });
  pub->on([](Satellite& s) {
    for (int i = 0; i < 200; ++i) ASSERT_TRUE(s.publish("numbers", std::to_string(i)));
  });
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.numbers:") == 200; }))
      << sub->events.count("data:");
  const auto data = sub->events.with("data:guest.numbers:");
  for (int i = 0; i < 200; ++i) EXPECT_EQ(data[i], std::to_string(i));
  EXPECT_EQ(sub->on([&](Satellite&) { return viewed; }), data);
  const uint64_t writes = pub->on([](Satellite& s) { return s.stats().writes; }) - writes_before;
  EXPECT_LE(writes, 5u) << "frames of one iteration go out together";

  // Publishing on someone else's channel, or an unknown one, is refused locally.
  const uint16_t id = pub->on([](Satellite& s) { return *s.channelId("numbers"); });
  EXPECT_EQ(sub->on([&](Satellite& s) { return s.publish(id, "x").error().code; }),
            Errc::not_found);
  EXPECT_FALSE(pub->on([](Satellite& s) { return s.publish("nope", "x"); }));
}

TEST_F(Satellites, FirstAndLastSubscriberEvents) {
  auto pub = satellite("pub");
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.addChannel({.name = "camera"}); }));
  ASSERT_TRUE(eventually([&] { return pub->events.count("ready:guest.camera") == 1; }));
  EXPECT_FALSE(pub->on([](Satellite& s) { return s.hasSubscribers("camera"); }));
  auto a = satellite("a");
  auto b = satellite("b");
  a->on([](Satellite& s) { s.subscribe("guest.camera"); });
  ASSERT_TRUE(eventually([&] { return pub->events.count("start:") == 1; }));
  EXPECT_TRUE(pub->on([](Satellite& s) { return s.hasSubscribers("guest.camera"); }));
  b->on([](Satellite& s) { s.subscribe("guest.camera"); });
  ASSERT_TRUE(eventually([&] { return subscribers("guest.camera") == 2; }));
  a->on([](Satellite& s) { s.unsubscribe("guest.camera"); });
  b->on([](Satellite& s) { s.unsubscribe("guest.camera"); });
  ASSERT_TRUE(eventually([&] { return pub->events.count("stop:guest.camera") == 1; }));
  EXPECT_EQ(pub->events.count("start:"), 1u) << "the second subscriber is not announced";
  EXPECT_FALSE(pub->on([](Satellite& s) { return s.hasSubscribers("camera"); }));
}

TEST_F(Satellites, ASubscriptionAsksForItsQueueAndHearsWhenItIsClamped) {
  auto pub = satellite("pub");
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.addChannel({.name = "video"}); }));
  ASSERT_TRUE(eventually([&] { return pub->events.count("ready:guest.video") == 1; }));
  auto sub = satellite("sub");
  // Within the hub's cap (server.subscriber_queue_max_bytes, 64 MiB by default): no answer.
  sub->on([](Satellite& s) { s.subscribe("guest.video", size_t{32} << 20); });
  ASSERT_TRUE(eventually([&] { return pub->events.count("start:guest.video") == 1; }));
  // Above it: clamped, told, and still subscribed.
  sub->on([](Satellite& s) { s.subscribe("guest.video", size_t{1} << 30); });
  ASSERT_TRUE(eventually([&] { return sub->events.count("error:") == 1; })) << sub->events.dump();
  EXPECT_EQ(sub->events.count("error:subscribed with a queue of 67108864 bytes"), 1u)
      << sub->events.dump();
  EXPECT_TRUE(sub->on([](Satellite& s) { return s.isSubscribed("guest.video"); }));
  pub->on([](Satellite& s) { ASSERT_TRUE(s.publish("video", "frame")); });
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.video:frame") == 1; }));
  EXPECT_EQ(subscribers("guest.video"), 1u);
}

TEST_F(Satellites, ChannelPropertiesAreReadByAnother) {
  auto pub = satellite("mic");
  ASSERT_TRUE(pub->on([](Satellite& s) {
    return s.addChannel({.name = "audio",
                         .mime = "audio/pcm",
                         .props = Variant::Map{{"rate", 16000}, {"format", "s16le"}}});
  }));
  auto sub = satellite("listener");
  ASSERT_TRUE(eventually(
      [&] { return sub->on([](Satellite& s) { return s.channel("guest.audio") != nullptr; }); }));
  const ChannelInfo info = sub->on([](Satellite& s) { return *s.channel("guest.audio"); });
  EXPECT_EQ(info.mime, "audio/pcm");
  EXPECT_EQ(*info.props.find("rate"), Variant(16000));
  // The channel's database, read by blocking request over the synchronous connection.
  auto rate = sub->on([](Satellite& s) { return s.get("rate", "guest.audio"); });
  ASSERT_TRUE(rate) << rate.error().message;
  EXPECT_EQ(*rate, Variant(16000));
  // Changed properties reach everyone.
  ASSERT_TRUE(pub->on([](Satellite& s) {
    return s.setChannelProperties("audio", {{"rate", 48000}, {"format", nullptr}});
  }));
  ASSERT_TRUE(eventually([&] {
    return sub->events.count("changed:guest.audio:{\"rate\":48000}") == 1;
  })) << sub->events.dump();
}

TEST_F(Satellites, RemovedChannelsAndSubscriptionsThatFollowThem) {
  auto pub = satellite("pub");
  auto sub = satellite("sub");
  sub->on([](Satellite& s) { s.subscribe("guest.temp"); });
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.addChannel({.name = "temp"}); }));
  ASSERT_TRUE(eventually([&] { return sub->events.count("subscribed:guest.temp") == 1; }));
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.removeChannel("temp"); }));
  ASSERT_TRUE(eventually([&] { return sub->events.count("removed:guest.temp") == 1; }));
  EXPECT_FALSE(sub->on([](Satellite& s) { return s.isSubscribed("guest.temp"); }));
  // Created again (a new instance): the subscription by name follows it.
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.addChannel({.name = "temp"}); }));
  ASSERT_TRUE(eventually([&] { return sub->events.count("subscribed:guest.temp") == 2; }));
  ASSERT_TRUE(eventually([&] { return pub->events.count("start:guest.temp") == 2; }));
  // Removed before the hub even made it: it does not stay behind.
  pub->on([](Satellite& s) {
    ASSERT_TRUE(s.addChannel({.name = "ghost"}));
    ASSERT_TRUE(s.removeChannel("ghost"));
  });
  ASSERT_TRUE(eventually([&] { return sub->events.count("removed:guest.ghost") == 1; }));
  EXPECT_EQ(pub->on([](Satellite& s) { return s.addChannel({.name = "temp"}).error().code; }),
            Errc::already_exists);
  EXPECT_EQ(pub->on([](Satellite& s) { return s.addChannel({.name = ".bad"}).error().code; }),
            Errc::invalid_argument);
}

TEST_F(Satellites, ServiceRoundTripAsyncAndBlocking) {
  auto provider = satellite("provider");
  provider->on([](Satellite& s) {
    ASSERT_TRUE(s.addChannel({.name = "math", .kind = flow::ChannelKind::service}));
    s.serviceRequest.connect(&s, [&s](const Request& r) {
      if (r.command == "double") (void)s.respond(r, *r.value.asInt64() * 2);
      // "silent" is never answered
    });
  });
  ASSERT_TRUE(eventually([&] { return provider->events.count("ready:guest.math") == 1; }));
  auto caller = satellite("caller");
  ASSERT_TRUE(eventually(
      [&] { return caller->on([](Satellite& s) { return s.channel("guest.math") != nullptr; }); }));
  // Asynchronous: the answer comes to the handler and as the serviceResponse signal.
  auto answer = std::make_shared<Events>();
  auto tag = caller->on([&](Satellite& s) {
    return s.request("guest.math", "double", 21, [answer](const Response& r) {
      answer->add(flow::variantToJsonText(r.value));
    });
  });
  ASSERT_TRUE(tag) << tag.error().message;
  ASSERT_TRUE(eventually([&] { return answer->count("42") == 1; }));
  EXPECT_EQ(caller->events.count("response:" + std::to_string(*tag) + ":42"), 1u);
  // Blocking: over the synchronous connection.
  auto v = caller->on([](Satellite& s) { return s.call("guest.math", "double", 50); });
  ASSERT_TRUE(v) << v.error().message;
  EXPECT_EQ(*v, Variant(100));
  auto slow = caller->on([](Satellite& s) { return s.call("guest.math", "silent", 1, 200); });
  ASSERT_FALSE(slow);
  EXPECT_EQ(slow.error().code, Errc::timeout);
  auto none = caller->on([](Satellite& s) { return s.request("guest.nope", "x", 1); });
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, Errc::not_found);
  // The flow goes on after a timed-out blocking call.
  ASSERT_TRUE(caller->on([](Satellite& s) { return s.request("guest.math", "double", 2); }));
  ASSERT_TRUE(eventually([&] { return caller->events.count("response:") == 2; }));
  // An asynchronous request with a timeout (1.4) that nobody answers fails with timeout.
  auto expired = std::make_shared<Events>();
  ASSERT_TRUE(caller->on([&](Satellite& s) {
    return s.request(
        "guest.math", "silent", 1,
        [expired](const Response& r) { expired->add(std::string(flow::errorCodeName(r.error))); },
        100);
  }));
  ASSERT_TRUE(eventually([&] { return expired->count("timeout") == 1; }));
}

// The sync pulse: a source of one satellite, followed by another (kept across re-creation),
// every pulse and then every second one; the follower answers each once its slots returned.
TEST_F(Satellites, SyncPulsesFromASourceToAFollower) {
  auto source = satellite("source");
  source->on([](Satellite& s) {
    ASSERT_TRUE(s.addChannel({.name = "clock", .kind = flow::ChannelKind::sync}));
  });
  ASSERT_TRUE(eventually([&] { return source->events.count("ready:guest.clock") == 1; }));
  auto target = satellite("target");
  target->on([](Satellite& s) { s.follow("guest.clock"); });
  ASSERT_TRUE(eventually([&] { return target->events.count("subscribed:guest.clock") == 1; }));
  // A round trip on the follower's flow: the hub has its SYNC_FOLLOW.
  ASSERT_TRUE(target->on([](Satellite& s) { return s.syncDatabases(); }));
  ASSERT_TRUE(eventually([&] { return target->events.count("synced:") == 1; }));
  for (int i = 1; i <= 5; ++i) {
    ASSERT_TRUE(source->on([](Satellite& s) { return s.pulse("clock"); }));
    // The next one only once this one was handled: SYNC_DONE reached the hub before it.
    ASSERT_TRUE(eventually([&] { return target->events.count("pulse:") == size_t(i); }));
    ASSERT_TRUE(target->on([](Satellite& s) { return s.syncDatabases(); }));
    ASSERT_TRUE(eventually([&] { return target->events.count("synced:") == size_t(i + 1); }));
  }
  EXPECT_EQ(target->events.with("pulse:guest.clock:"),
            (std::vector<std::string>{"1:0", "2:0", "3:0", "4:0", "5:0"}));
  auto bad = source->on([](Satellite& s) { return s.pulse("nope"); });
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, Errc::not_found);
  target->on([](Satellite& s) { s.unfollow("guest.clock"); });
  ASSERT_TRUE(target->on([](Satellite& s) { return s.syncDatabases(); }));
  ASSERT_TRUE(eventually([&] { return target->events.count("synced:") == 7; }));
  ASSERT_TRUE(source->on([](Satellite& s) { return s.pulse("clock"); }));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(target->events.count("pulse:"), 5u) << "a pulse after unfollow";
}

// The hub as a source: "sync.hub_source" pulses hub.<name> on each of the hub's fast ticks.
TEST(HubSyncSource, TheHubPulsesItsOwnSourceOnItsFastTick) {
  TempDir dir;
  HubProcess hub(SKROBOT_BIN, dir.path(), {}, {},
                 R"("sync": {"hub_source": "tick"}, "loop": {"fast_tick_ms": 10}, )");
  ASSERT_TRUE(hub.start()) << hub.log();
  SatelliteOptions o;
  o.connection.address = Address::parse("local:" + (dir.path() / "hub.sock").string()).value();
  SatOnThread target(o);
  target.start();
  target.on([](Satellite& s) { s.follow("hub.tick"); });
  ASSERT_TRUE(eventually([&] { return target.events.count("pulse:hub.tick:") >= 20; }))
      << target.events.dump();
  const ChannelInfo info = target.on([](Satellite& s) { return *s.channel("hub.tick"); });
  EXPECT_EQ(info.kind, uint8_t(flow::ChannelKind::sync));
}

TEST_F(Satellites, DatabasesWrittenOnTheFlowReadBlocking) {
  auto s = satellite("db");
  ASSERT_TRUE(s->on([](Satellite& x) { return x.set("speed", 1.5); }));
  ASSERT_TRUE(eventually([&] {
    auto v = s->on([](Satellite& x) { return x.get("speed"); });
    return v && *v == Variant(1.5);
  }));
  ASSERT_TRUE(s->on([](Satellite& x) { return x.createDatabase("calibration"); }));
  ASSERT_TRUE(s->on([](Satellite& x) { return x.set("offset", -2, "calibration"); }));
  ASSERT_TRUE(s->on([](Satellite& x) { return x.set("gain", 3); }));  // back in the user's db
  ASSERT_TRUE(eventually([&] {
    auto v = s->on([](Satellite& x) { return x.get("gain"); });
    return v && *v == Variant(3);
  }));
  auto offset = s->on([](Satellite& x) { return x.get("offset", "calibration"); });
  ASSERT_TRUE(offset) << offset.error().message;
  EXPECT_EQ(*offset, Variant(-2));
  auto keys = s->on([](Satellite& x) { return x.keys(); });
  ASSERT_TRUE(keys);
  EXPECT_EQ(*keys, (std::vector<std::string>{"gain", "speed"}));
  ASSERT_TRUE(s->on([](Satellite& x) { return x.del("speed"); }));
  ASSERT_TRUE(eventually([&] {
    return s->on([](Satellite& x) {
      auto r = x.get("speed");
      return !r && r.error().code == Errc::not_found;
    });
  }));
  // The barrier for writes without a reply, on the flow and on the synchronous connection.
  ASSERT_TRUE(s->on([](Satellite& x) { return x.set("synced", true, "calibration"); }));
  auto tag = s->on([](Satellite& x) { return x.syncDatabases(); });
  ASSERT_TRUE(tag) << tag.error().message;
  ASSERT_TRUE(eventually([&] { return s->events.count("synced:" + std::to_string(*tag)) == 1; }))
      << s->events.dump();
  auto blocking = s->on([](Satellite& x) -> Result<void> {
    auto sync = x.syncClient();
    if (!sync) return sync.error();
    return (*sync)->syncDatabases();
  });
  EXPECT_TRUE(blocking) << blocking.error().message;
  // A refused write comes back as an error event.
  ASSERT_TRUE(s->on([](Satellite& x) { return x.set("k", 1, "no-such-db"); }));
  ASSERT_TRUE(eventually([&] { return s->events.count("error:") >= 1; })) << s->events.dump();
}

TEST_F(Satellites, BlobChannelsKeepFilesAndTellSubscribers) {
  auto owner = satellite("mapper");
  ASSERT_TRUE(owner->on([](Satellite& x) {
    return x.addChannel({.name = "maps", .kind = flow::ChannelKind::blob});
  }));
  ASSERT_TRUE(eventually([&] { return owner->events.count("ready:guest.maps") == 1; }));
  auto reader = satellite("navigator");
  std::vector<BlobChange> changes;
  std::mutex m;
  reader->on([&](Satellite& x) {
    x.blobChanged.connect(&x, [&](const BlobChange& c) {
      const std::lock_guard lock(m);
      changes.push_back(c);
    });
    x.subscribe("guest.maps");
  });
  ASSERT_TRUE(eventually([&] { return reader->events.count("subscribed:guest.maps") == 1; }));
  auto version = owner->on([](Satellite& x) -> Result<uint64_t> {
    auto sync = x.syncClient();
    if (!sync) return sync.error();
    const ChannelInfo* ch = x.channel("guest.maps");
    if (ch == nullptr) return makeError(Errc::not_found, "no guest.maps");
    return (*sync)->blobPut(ch->id, "floor1.pgm", "P5 2 2 255 abcd");
  });
  ASSERT_TRUE(version) << version.error().message;
  ASSERT_TRUE(eventually([&] {
    const std::lock_guard lock(m);
    return !changes.empty();
  }));
  {
    const std::lock_guard lock(m);
    EXPECT_EQ(changes[0].path, "floor1.pgm");
    EXPECT_EQ(changes[0].change, flow::msg::BlobChange::written);
    EXPECT_EQ(changes[0].size, 15u);
    EXPECT_EQ(changes[0].version, *version);
  }
  auto got = reader->on([](Satellite& x) -> Result<std::string> {
    auto sync = x.syncClient();
    if (!sync) return sync.error();
    auto info = (*sync)->channel("guest.maps");
    if (!info) return info.error();
    return (*sync)->blobGet(info->id, "floor1.pgm");
  });
  ASSERT_TRUE(got) << got.error().message;
  EXPECT_EQ(*got, "P5 2 2 255 abcd");
  // The mapper goes; its maps stay, and come back to it when it does.
  owner.reset();
  auto again = satellite("mapper-again");
  ASSERT_TRUE(again->on([](Satellite& x) {
    return x.addChannel({.name = "maps", .kind = flow::ChannelKind::blob});
  }));
  ASSERT_TRUE(eventually([&] { return again->events.count("ready:guest.maps") == 1; }))
      << again->events.dump();
  auto listed = again->on([](Satellite& x) -> Result<size_t> {
    auto sync = x.syncClient();
    if (!sync) return sync.error();
    auto list = (*sync)->blobList(x.channel("guest.maps")->id);
    if (!list) return list.error();
    return list->size();
  });
  ASSERT_TRUE(listed) << listed.error().message;
  EXPECT_EQ(*listed, 1u);
}

}  // namespace
}  // namespace skr::sat::test

namespace skr::sat::test {
namespace {

class OverTcp : public SatTest {};

TEST_F(OverTcp, PublishAndSubscribeWithARealAccount) {
  startHub("alice");
  const std::string tcp = hub_->tcpAddress();
  ASSERT_FALSE(tcp.empty()) << hubLog();
  SatelliteOptions o = options("tcp");
  o.connection.address = Address::parse(tcp).value();
  o.connection.user = "alice";
  o.connection.password = "s3cret-pass";
  SatOnThread pub(o);
  SatOnThread sub(o);
  ASSERT_TRUE(pub.on([](Satellite& s) { return s.addChannel({.name = "lidar"}); }));
  sub.on([](Satellite& s) { s.subscribe("alice.lidar"); });
  pub.start();
  sub.start();
  ASSERT_TRUE(eventually([&] { return pub.events.count("start:alice.lidar") == 1; }))
      << pub.events.dump() << hubLog();
  ASSERT_TRUE(pub.on([](Satellite& s) { return s.publish("lidar", "scan"); }));
  ASSERT_TRUE(eventually([&] { return sub.events.count("data:alice.lidar:scan") == 1; }));
  // The development account is refused on TCP: the satellite says why and keeps trying.
  o.connection.user = "guest";
  o.connection.password = "password";
  SatOnThread guest(o);
  guest.start();
  ASSERT_TRUE(eventually([&] { return guest.events.count("error:") >= 1; }));
  EXPECT_FALSE(guest.connected());
}

// Two pseudo-terminals joined back to back: what is written to one's slave is read from the
// other's, as on a cable between two serial ports.
class NullModem {
 public:
  NullModem() {
    for (auto& end : ends_) {
      end.master = ::posix_openpt(O_RDWR | O_NOCTTY);
      EXPECT_GE(end.master, 0);
      EXPECT_EQ(::grantpt(end.master), 0);
      EXPECT_EQ(::unlockpt(end.master), 0);
      end.slave = ::ptsname(end.master);
      termios t{};
      ::tcgetattr(end.master, &t);
      ::cfmakeraw(&t);
      ::tcsetattr(end.master, TCSANOW, &t);
    }
    thread_ = std::thread([this] { copy(); });
  }
  ~NullModem() {
    stop_ = true;
    thread_.join();
    for (auto& end : ends_) ::close(end.master);
  }
  NullModem(const NullModem&) = delete;
  NullModem& operator=(const NullModem&) = delete;
  [[nodiscard]] const std::string& device(int i) const { return ends_[i].slave; }

 private:
  void copy() {
    char buf[4096];
    while (!stop_) {
      pollfd p[2] = {{ends_[0].master, POLLIN, 0}, {ends_[1].master, POLLIN, 0}};
      if (::poll(p, 2, 50) <= 0) continue;
      for (int i = 0; i < 2; ++i) {
        if ((p[i].revents & POLLIN) == 0) continue;
        const ssize_t n = ::read(ends_[i].master, buf, sizeof buf);
        if (n > 0) (void)!::write(ends_[1 - i].master, buf, static_cast<size_t>(n));
      }
    }
  }
  struct End {
    int master = -1;
    std::string slave;
  };
  End ends_[2];
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class OverSerial : public SatTest {};

TEST_F(OverSerial, ASatelliteOnASerialLinePublishesToOneOnTheSocket) {
  NullModem line;
  hub_ = std::make_unique<HubProcess>(
      SKROBOT_BIN, dir_.path(), "alice",
      R"(, "serial": [{"device": ")" + line.device(0) + R"(", "account": "alice"}])");
  startHub();
  SatelliteOptions o = options("board");
  auto serial = Address::parse("serial:" + line.device(1) + "@115200");
  ASSERT_TRUE(serial) << serial.error().message;
  o.connection.address = *serial;
  o.connection.user = "alice";
  SatOnThread board(o);
  auto sub = satellite("socket");
  ASSERT_TRUE(board.on([](Satellite& s) { return s.addChannel({.name = "analog"}); }));
  sub->on([](Satellite& s) { s.subscribe("alice.analog"); });
  board.start();
  ASSERT_TRUE(eventually([&] { return board.events.count("start:alice.analog") == 1; }))
      << board.events.dump() << hubLog();
  ASSERT_TRUE(board.on([](Satellite& s) { return s.publish("analog", "512"); }));
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:alice.analog:512") == 1; }))
      << sub->events.dump() << hubLog();
}

class OverUdp : public SatTest {};

TEST_F(OverUdp, ASatelliteOnUdpPublishesAndSubscribesThroughTheHub) {
  startUdpHub();
  SatOnThread board(udpOptions("board"));
  auto socket = satellite("socket");
  ASSERT_TRUE(board.on([](Satellite& s) { return s.addChannel({.name = "analog"}); }));
  ASSERT_TRUE(socket->on([](Satellite& s) { return s.addChannel({.name = "led"}); }));
  board.on([](Satellite& s) { s.subscribe("guest.led"); });
  socket->on([](Satellite& s) { s.subscribe("alice.analog"); });
  board.start();
  // Publishing: the board's channel has a subscriber on the socket.
  ASSERT_TRUE(eventually([&] { return board.events.count("start:alice.analog") == 1; }))
      << board.events.dump() << hubLog();
  ASSERT_TRUE(board.on([](Satellite& s) { return s.publish("analog", "512"); }));
  ASSERT_TRUE(eventually([&] { return socket->events.count("data:alice.analog:512") == 1; }))
      << socket->events.dump() << hubLog();
  // Subscribing: the socket's channel reaches the board over UDP.
  ASSERT_TRUE(eventually([&] { return socket->events.count("start:guest.led") == 1; }))
      << socket->events.dump() << board.events.dump() << hubLog();
  ASSERT_TRUE(socket->on([](Satellite& s) { return s.publish("led", "on"); }));
  ASSERT_TRUE(eventually([&] { return board.events.count("data:guest.led:on") == 1; }))
      << board.events.dump() << hubLog();
  EXPECT_EQ(board.events.count("connected"), 1u) << board.events.dump();
}

// The hub ends a UDP session that sends nothing for session_timeout_ms: the satellite's flow
// keeps itself alive (a TIME_PROBE every 2 s), so an idle subscriber stays connected.
TEST_F(OverUdp, AnIdleSatelliteKeepsItsSession) {
  startUdpHub(3000);
  SatOnThread board(udpOptions("board"));
  auto socket = satellite("socket");
  ASSERT_TRUE(socket->on([](Satellite& s) { return s.addChannel({.name = "led"}); }));
  board.on([](Satellite& s) { s.subscribe("guest.led"); });
  board.start();
  ASSERT_TRUE(eventually([&] { return socket->events.count("start:guest.led") == 1; }))
      << socket->events.dump() << board.events.dump() << hubLog();
  std::this_thread::sleep_for(std::chrono::milliseconds(5000));  // past the hub's 3000 ms
  ASSERT_TRUE(socket->on([](Satellite& s) { return s.publish("led", "on"); }));
  ASSERT_TRUE(eventually([&] { return board.events.count("data:guest.led:on") == 1; }))
      << board.events.dump() << hubLog();
  EXPECT_EQ(board.events.count("connected"), 1u) << board.events.dump();
  EXPECT_EQ(board.events.count("disconnected"), 0u) << board.events.dump();
}

TEST_F(OverUdp, AWrongKeyIsAClearErrorAfterTheHandshakeTimeout) {
  startUdpHub();
  SatelliteOptions o = udpOptions("board");
  (*o.connection.udp_key)[0] ^= 1;
  o.connection.timeout_ms = 1000;
  o.reconnect = false;
  SatOnThread board(o);
  board.start();
  ASSERT_TRUE(eventually([&] { return board.events.count("error:") == 1; }))
      << board.events.dump() << hubLog();
  const std::string error = board.events.with("error:")[0];
  EXPECT_NE(error.find("the hub answered the HELLO but not the OPEN within 1000 ms: the key is "
                       "not account \"alice\"'s"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("udp:127.0.0.1:" + std::to_string(udp_port_)), std::string::npos) << error;
  EXPECT_FALSE(board.connected());
  // No key at all: said at once.
  o.connection.udp_key.reset();
  SatOnThread keyless(o);
  keyless.start();
  ASSERT_TRUE(eventually([&] { return keyless.events.count("error:") == 1; }))
      << keyless.events.dump();
  EXPECT_NE(keyless.events.with("error:")[0].find("ROBOT_UDP_KEY"), std::string::npos)
      << keyless.events.dump();
}

}  // namespace
}  // namespace skr::sat::test
