// SPDX-License-Identifier: Apache-2.0
// Satellites recover by themselves: a hub restarted under them, and a "hub" that sends garbage.
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/log.h>

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>

#include <atomic>
#include <csignal>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

using flow::Variant;
namespace msg = flow::msg;

class Reconnect : public SatTest {};

TEST_F(Reconnect, HubRestartUnderRunningPublisherAndSubscriber) {
  startHub();
  auto pub = satellite("pub");
  ASSERT_TRUE(pub->on([](Satellite& s) {
    return s.addChannel({.name = "counter", .props = Variant::Map{{"unit", "ticks"}}});
  }));
  auto sub = satellite("sub");
  sub->on([](Satellite& s) { s.subscribe("guest.counter"); });
  ASSERT_TRUE(eventually([&] { return pub->events.count("start:guest.counter") == 1; }));
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.publish("counter", "before"); }));
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.counter:before") == 1; }));

  ASSERT_EQ(hub_->stop(), 0);
  ASSERT_TRUE(eventually([&] {
    return pub->events.count("disconnected:") == 1 && sub->events.count("disconnected:") == 1;
  }));
  EXPECT_FALSE(pub->connected());
  EXPECT_EQ(pub->on([](Satellite& s) { return s.publish("counter", "lost").error().code; }),
            Errc::closed);

  startHub();  // same socket, a new hub: new connection ids, channels to re-create
  ASSERT_TRUE(eventually([&] {
    return pub->events.count("ready:guest.counter") == 2 &&
           sub->events.count("subscribed:guest.counter") == 2 &&
           pub->events.count("start:guest.counter") == 2;
  })) << pub->events.dump()
      << sub->events.dump() << hubLog();
  EXPECT_EQ(pub->events.count("connected"), 2u);
  // Same name, same properties, and data flows again.
  const ChannelInfo info = sub->on([](Satellite& s) { return *s.channel("guest.counter"); });
  EXPECT_EQ(*info.props.find("unit"), Variant("ticks"));
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.publish("counter", "after"); }));
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.counter:after") == 1; }));
}

// A Unix socket server that answers each connection with the next script of bad bytes, from
// script `first` (3: every connection logs in, then gets a bad frame on its flow).
class GarbageHub {
 public:
  explicit GarbageHub(const fs::path& path, int first = 0) : path_(path), first_(first) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    EXPECT_EQ(::listen(fd_, 8), 0);
    thread_ = std::thread([this] { serve(); });
  }
  ~GarbageHub() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
    fs::remove(path_);
  }
  GarbageHub(const GarbageHub&) = delete;
  GarbageHub& operator=(const GarbageHub&) = delete;
  GarbageHub(GarbageHub&&) = delete;
  GarbageHub& operator=(GarbageHub&&) = delete;
  [[nodiscard]] int accepted() const { return accepted_.load(); }

 private:
  static bool readSome(int fd) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 2000) <= 0) return false;
    char buf[4096];
    return ::recv(fd, buf, sizeof buf, 0) > 0;
  }
  static void sendAll(int fd, const std::string& bytes) {
    (void)!::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  }
  static std::string handshake() {
    std::string out;
    EXPECT_TRUE(flow::encode(out, msg::LoginOk{1, 0, 7, "garbage", "guest", "guest"}));
    return out;
  }
  void serve() {
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      const int c = ::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (c < 0) continue;
      const int script = first_ + accepted_++ % (5 - first_);
      if (readSome(c)) {  // the LOGIN
        switch (script) {
          case 0:
            sendAll(c, std::string("\0\0\0\0", 4));  // a frame of length 0
            break;
          case 1:
            sendAll(c, "\xff\xff\xff\xff\x80");  // 4 GiB announced
            break;
          case 2:
            sendAll(c, std::string("\x03\0\0\0\x80\x01\0", 7));  // a truncated LOGIN reply
            break;
          default: {  // a proper handshake, then a bad frame on the flow
            sendAll(c, handshake());
            readSome(c);  // CHAN_LIST + GO_ASYNC
            std::string reply;
            EXPECT_TRUE(flow::encode(reply, msg::ChannelList{}));
            flow::appendHeader(reply, flow::Code::reply_ok, 0);
            if (script == 3) {
              flow::appendHeader(reply, flow::Code::var_get, 0);  // a request code, from a hub
            } else {
              reply += std::string("\x02\0\0\0\x97\x01", 6);  // EV_DATA, 1 byte of a u16
            }
            sendAll(c, reply);
          }
        }
      }
      char buf[256];
      pollfd q{c, POLLIN, 0};
      while (::poll(&q, 1, 2000) > 0 && ::recv(c, buf, sizeof buf, 0) > 0) {
      }  // until the satellite hangs up
      ::close(c);
    }
  }

  fs::path path_;
  int first_ = 0;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<int> accepted_{0};
  std::thread thread_;
};

TEST_F(Reconnect, GarbageFromTheHubDropsTheConnectionAndRetries) {
  const fs::path socket = dir_.path() / "hub.sock";
  auto garbage = std::make_unique<GarbageHub>(socket);
  auto s = satellite("victim", false);
  ASSERT_TRUE(s->on([](Satellite& x) { return x.addChannel({.name = "survivor"}); }));
  ASSERT_TRUE(eventually([&] {
    return s->on([](Satellite& x) { return x.stats().protocol_errors; }) >= 5;
  })) << s->events.dump();
  EXPECT_GE(garbage->accepted(), 5);
  EXPECT_GE(s->events.count("connected"), 2u) << "scripts 3 and 4 open the flow first";
  EXPECT_GE(s->events.count("disconnected:"), 2u);
  // A real hub at the same place: the satellite settles there, channel and all.
  garbage.reset();
  startHub();
  ASSERT_TRUE(eventually([&] { return s->events.count("ready:guest.survivor") == 1; }))
      << s->events.dump() << hubLog();
  EXPECT_TRUE(s->connected());
}

// The delays between attempts grow (100 ms doubling to 2 s) even when every attempt logs in:
// only a flow that stayed open resets them. Attempts start at 0, 0.1, 0.3, 0.7, 1.5 and 3.1 s.
TEST_F(Reconnect, AHubThatKeepsDroppingTheFlowSeesGrowingDelays) {
  const fs::path socket = dir_.path() / "hub.sock";
  GarbageHub garbage(socket, 3);
  auto s = satellite("victim", false);
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  const int logins = garbage.accepted();
  EXPECT_GE(s->events.count("connected"), 3u) << s->events.dump();
  EXPECT_GE(logins, 3);
  EXPECT_LE(logins, 7) << "a reconnection storm: " << logins << " logins in 3 s";
}

// Lines logged with a given tag, from any thread.
class LogTag {
 public:
  explicit LogTag(std::string tag) : tag_(std::move(tag)) { log::setHook(&LogTag::hook, this); }
  ~LogTag() { log::setHook(nullptr, nullptr); }
  LogTag(const LogTag&) = delete;
  LogTag& operator=(const LogTag&) = delete;
  LogTag(LogTag&&) = delete;
  LogTag& operator=(LogTag&&) = delete;
  [[nodiscard]] std::vector<std::string> lines() const {
    std::lock_guard lock(m_);
    return lines_;
  }

 private:
  static void hook(log::Level, std::string_view, std::string_view tag, std::string_view message,
                   void* user) {
    auto* self = static_cast<LogTag*>(user);
    if (tag != self->tag_) return;
    std::lock_guard lock(self->m_);
    self->lines_.emplace_back(message);
  }
  std::string tag_;
  mutable std::mutex m_;
  std::vector<std::string> lines_;
};

// A slot of the application that throws is the application's error: logged as such, and the
// flow stays up (no reconnection), the next frames are handled.
TEST_F(Reconnect, ASlotThatThrowsDoesNotDropTheFlow) {
  startHub();
  const LogTag logged("SAT-SLOT-EXCEPTION");
  auto pub = satellite("pub");
  auto sub = satellite("sub");
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.addChannel({.name = "feed"}); }));
  sub->on([](Satellite& s) {
    s.data.connect(&s, [](uint16_t, const std::string& payload) {
      if (payload == "boom") throw std::runtime_error("the application's own bug");
    });
    (void)s.subscribe("guest.feed");
  });
  ASSERT_TRUE(eventually([&] { return pub->events.count("start:guest.feed") == 1; }));
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.publish("feed", "boom"); }));
  ASSERT_TRUE(pub->on([](Satellite& s) { return s.publish("feed", "after"); }));
  ASSERT_TRUE(eventually([&] { return sub->events.count("data:guest.feed:after") == 1; }))
      << sub->events.dump();
  EXPECT_EQ(sub->events.count("disconnected"), 0u) << sub->events.dump();
  EXPECT_EQ(sub->on([](Satellite& s) { return s.stats().connections; }), 1u);
  EXPECT_EQ(sub->on([](Satellite& s) { return s.stats().slot_exceptions; }), 1u);
  EXPECT_EQ(sub->on([](Satellite& s) { return s.stats().protocol_errors; }), 0u);
  const auto lines = logged.lines();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("the application's own bug"), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find("not of the hub"), std::string::npos) << lines[0];
}

TEST_F(Reconnect, SatelliteStartedBeforeTheHubConnectsWhenItComes) {
  auto s = satellite("early", false);
  s->on([](Satellite& x) { x.subscribe("guest.later"); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_FALSE(s->connected());
  startHub();
  ASSERT_TRUE(eventually([&] { return s->connected(); })) << hubLog();
  auto pub = satellite("later");
  ASSERT_TRUE(pub->on([](Satellite& x) { return x.addChannel({.name = "later"}); }));
  ASSERT_TRUE(eventually([&] { return s->events.count("subscribed:guest.later") == 1; }));
}

// A hub that closes the connection while the satellite writes must not kill the process: the
// library ignores SIGPIPE once it opens a connection (unless the process chose otherwise).
TEST_F(Reconnect, TheFirstConnectionAttemptLeavesSigpipeIgnored) {
  struct sigaction now {};
  ASSERT_EQ(::sigaction(SIGPIPE, nullptr, &now), 0);
  ASSERT_EQ(now.sa_handler, SIG_DFL);  // each test runs in a process of its own
  auto s = satellite("early", false);  // nobody listens: the attempt is enough
  EXPECT_TRUE(eventually([&] {
    ::sigaction(SIGPIPE, nullptr, &now);
    return now.sa_handler == SIG_IGN;
  }));
}

TEST_F(Reconnect, StopMeansNoReconnection) {
  startHub();
  auto s = satellite("quitter");
  s->on([](Satellite& x) { x.stop(); });
  EXPECT_FALSE(s->connected());
  EXPECT_EQ(s->events.count("disconnected:stopped"), 1u);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_FALSE(s->connected());
  s->start();
  ASSERT_TRUE(eventually([&] { return s->connected(); }));
}

}  // namespace
}  // namespace skr::sat::test
