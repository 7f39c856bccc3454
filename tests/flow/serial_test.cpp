// SPDX-License-Identifier: Apache-2.0
// Boards on serial lines (skrobot/runtime/flow/serial.h, server.serial): a pseudo-terminal stands
// for the line, the test holds the board's end and speaks the line framing (skr_line.h). One
// session at a time on a port; a LOGIN restarts it; a protocol error ends the session, not the
// port; noise is dropped and counted; SESSION_LIMITS (1.12) keeps large frames and other
// channels' events away; a device that goes away is reopened when it comes back.
#include "flow_fixture.h"
#include "log_capture.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/flow/hub_stats.h>

#include "skr_line.h"

#include <fcntl.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>

namespace skr::test {
namespace {

using namespace skr::flow;

// A pseudo-terminal: the master is the board's end, the slave's name the hub's device.
struct Pty {
  int master = -1;
  std::string slave;
  static Pty open() {
    Pty p;
    p.master = ::posix_openpt(O_RDWR | O_NOCTTY);
    EXPECT_GE(p.master, 0);
    EXPECT_EQ(::grantpt(p.master), 0);
    EXPECT_EQ(::unlockpt(p.master), 0);
    p.slave = ::ptsname(p.master);
    termios t{};
    ::tcgetattr(p.master, &t);
    ::cfmakeraw(&t);
    ::tcsetattr(p.master, TCSANOW, &t);
    return p;
  }
};

class Serial : public FlowFixture {
 protected:
  // A hub with the accounts alice (password "right") and board, and one serial port.
  void startWith(const std::string& device, const std::string& account) {
    auto o = defaults();
    o.users_file = dir_.path() / "users.json";
    auto users = UsersFile::load(o.users_file);
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->add("alice", "right"));
    ASSERT_TRUE(users->add("board", "board-secret"));
    ASSERT_TRUE(users->save());
    transport::SerialOptions port;
    port.device = device;
    port.account = account;
    port.max_frame = 512;
    o.serial.push_back(port);
    ASSERT_TRUE(startHub(o));
  }
  void startBound() {
    pty_ = Pty::open();
    startWith(pty_.slave, "board");
  }
  TestClient board() { return TestClient::overLine(::dup(pty_.master)); }

  // LOGIN, SESSION_LIMITS, GO_ASYNC: a small session as a board opens it.
  void smallSession(TestClient& b, uint32_t max_frame, const std::string& watch) {
    auto ok = b.login("", "");
    ASSERT_TRUE(ok) << ok.error().message;
    EXPECT_EQ(ok->user, "board");
    auto r = b.call(msg::SessionLimits{max_frame, 0, watch});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->kind(), Code::reply_ok);
    r = b.call(msg::GoAsync{});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->kind(), Code::reply_ok);
  }

  // A new pseudo-terminal behind `link`: the hub opens it and a board logs in on it.
  void plugIn(const std::filesystem::path& link) {
    pty_ = Pty::open();
    std::filesystem::create_symlink(pty_.slave, link);
    ASSERT_TRUE(eventually([&] { return line().open; }, 5000));
    TestClient b = board();
    auto ok = b.login("", "");
    ASSERT_TRUE(ok) << ok.error().message;
  }

  SerialCounters line() {
    HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    EXPECT_EQ(s.serial.size(), 1u);
    return s.serial.empty() ? SerialCounters{} : s.serial.front();
  }

  ~Serial() override {
    if (pty_.master >= 0) ::close(pty_.master);
  }

  Pty pty_;
};

TEST_F(Serial, ABoardOnABoundPortPublishesSubscribesAndHearsOnlyOfItsChannels) {
  startBound();
  TestClient b = board();
  smallSession(b, 128, "alice.setpoint");
  TestClient alice = flowClient("alice", "right");

  // A channel it watches is announced; another one is not.
  const uint16_t other = addChannel(alice, "other");
  const uint16_t setpoint = addChannel(alice, "setpoint");
  auto ev = as<msg::EvChanAdded>(b.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->info.id, setpoint);
  EXPECT_EQ(ev->info.name, "alice.setpoint");

  // Its own channel, learnt from the tag; alice subscribes and gets its data.
  msg::ChanAdd add;
  add.tag = 5;
  add.kind = static_cast<uint8_t>(ChannelKind::streaming);
  add.short_name = "analog";
  add.mime = "application/octet-stream";
  add.props = Variant(Variant::Map{});
  ASSERT_TRUE(b.send(add));
  ev = as<msg::EvChanAdded>(b.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->tag, 5u);
  EXPECT_EQ(ev->info.name, "board.analog");
  const uint16_t analog = ev->info.id;
  ASSERT_TRUE(alice.send(msg::Subscribe{1, analog}));
  ASSERT_TRUE(b.waitFor(Code::ev_start_publish));
  ASSERT_TRUE(b.send(msg::Publish{analog, {"\x12\x34"}}));
  auto data = as<msg::EvData>(alice.waitFor(Code::ev_data));
  ASSERT_TRUE(data);
  EXPECT_EQ(data->payload.bytes, "\x12\x34");

  // What it subscribes to reaches it unless the frame is above its limit.
  ASSERT_TRUE(b.send(msg::Subscribe{2, setpoint}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(setpoint) == 1; }));
  ASSERT_TRUE(alice.send(msg::Publish{setpoint, {std::string(200, 'x')}}));
  ASSERT_TRUE(alice.send(msg::Publish{setpoint, {"small"}}));
  data = as<msg::EvData>(b.waitFor(Code::ev_data));
  ASSERT_TRUE(data);
  EXPECT_EQ(data->payload.bytes, "small");
  ASSERT_TRUE(eventually([&] { return stats().data_frames_dropped == 1; }));

  // Removing the channel it does not watch told it nothing; the one it subscribes to does.
  ASSERT_TRUE(alice.send(msg::ChanRemove{3, other}));
  ASSERT_TRUE(alice.send(msg::ChanRemove{4, setpoint}));
  auto removed = as<msg::EvChanRemoved>(b.waitFor(Code::ev_chan_removed));
  ASSERT_TRUE(removed);
  EXPECT_EQ(removed->chan_id, setpoint);

  const SerialCounters l = line();
  EXPECT_TRUE(l.open);
  EXPECT_TRUE(l.in_session);
  EXPECT_EQ(l.line.sessions, 1u);
  EXPECT_GT(l.line.frames_in, 5u);
  EXPECT_EQ(l.line.resyncs(), 0u);
}

TEST_F(Serial, ASlowLineKeepsTheNewestDataAndSendsEachFrameOnce) {
  startBound();
  TestClient alice = flowClient("alice", "right");
  const uint16_t fast = addChannel(alice, "fast");
  TestClient b = board();
  smallSession(b, 256, "alice.fast");
  ASSERT_TRUE(b.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(b.send(msg::Subscribe{1, fast}));
  ASSERT_TRUE(eventually([&] { return subscribersOf(fast) == 1; }));
  // Far more than the line's queue and the pseudo-terminal hold while the board does not read.
  constexpr uint32_t kCount = 3000;
  for (uint32_t i = 1; i <= kCount; ++i) {
    std::string payload(100, 'x');
    std::memcpy(payload.data(), &i, 4);
    ASSERT_TRUE(alice.send(msg::Publish{fast, {payload}}));
  }
  ASSERT_TRUE(eventually([&] {
    HubSnapshot s;
    onHub([&] { s = server_->snapshot(); });
    for (const auto& c : s.channels) {
      if (c.id == fast) return c.messages == kCount;
    }
    return false;
  }));
  // Each frame arrives once, in order, and the last one arrives.
  uint32_t last = 0, received = 0;
  while (last != kCount) {
    auto data = as<msg::EvData>(b.waitFor(Code::ev_data, 3000));
    ASSERT_TRUE(data) << "after " << last;
    uint32_t n = 0;
    std::memcpy(&n, data->payload.bytes.data(), 4);
    ASSERT_GT(n, last);
    last = n;
    ++received;
  }
  EXPECT_LT(received, kCount);  // the oldest were dropped, newest wins
  EXPECT_GT(stats().data_frames_dropped, 0u);
}

TEST_F(Serial, ChannelsThatExistAreAnnouncedWhenTheBoardGoesAsync) {
  startBound();
  TestClient alice = flowClient("alice", "right");
  const uint16_t setpoint = addChannel(alice, "setpoint");
  addChannel(alice, "other");
  TestClient b = board();
  smallSession(b, 256, "alice.set*");
  auto ev = as<msg::EvChanAdded>(b.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->info.id, setpoint);
  EXPECT_EQ(ev->tag, 0u);
  EXPECT_FALSE(b.waitFor(Code::ev_chan_added, 300));
}

TEST_F(Serial, SessionLimitsRefusesWhatItCannotKeep) {
  startBound();
  TestClient b = board();
  ASSERT_TRUE(b.login("", ""));
  auto r = b.call(msg::SessionLimits{32, 0, ""});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->kind(), Code::reply_error);
  r = b.call(msg::SessionLimits{128, 2, ""});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->kind(), Code::reply_error);
  r = b.call(msg::SessionLimits{128, 0, "a b**c***"});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->kind(), Code::reply_error);
  // A reply above the limit becomes an error the board can read.
  r = b.call(msg::SessionLimits{64, 1, ""});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->kind(), Code::reply_ok);
  r = b.call(msg::Ping{{std::string(100, 'p')}});
  ASSERT_TRUE(r);
  auto err = as<msg::ReplyError>(r);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::limit_exceeded));
}

TEST_F(Serial, NoiseIsDroppedAndCountedAndTheSessionGoesOn) {
  startBound();
  TestClient b = board();
  ASSERT_TRUE(b.login("", ""));
  // Garbage, a frame cut short by a delimiter, and a frame with a flipped bit.
  ASSERT_TRUE(b.sendLineBytes(std::string("\x05garbage\x00", 9)));
  ASSERT_TRUE(
      b.sendLineBytes(std::string("\x07"
                                  "abc\x00",
                                  5)));
  std::string ping;
  ASSERT_TRUE(encode(ping, msg::Ping{{"hello"}}));
  std::vector<uint8_t> wire(ping.size() + SKR_LINE_OVERHEAD(ping.size()));
  const size_t n = skr_line_encode(reinterpret_cast<const uint8_t*>(ping.data()), ping.size(),
                                   wire.data(), wire.size());
  wire[n / 2] ^= 0x10;
  ASSERT_TRUE(b.sendLineBytes({reinterpret_cast<const char*>(wire.data()), n}));
  // The session is still there: the next request is answered.
  auto r = b.call(msg::Ping{{"again"}});
  ASSERT_TRUE(r);
  auto pong = as<msg::Pong>(r);
  ASSERT_TRUE(pong);
  EXPECT_EQ(pong->echo.bytes, "again");
  const SerialCounters l = line();
  EXPECT_EQ(l.line.bad_check, 1u);    // the flipped frame
  EXPECT_EQ(l.line.bad_framing, 2u);  // COBS blocks cut short by a delimiter
  EXPECT_EQ(l.line.resyncs(), 3u);
  EXPECT_EQ(l.line.sessions, 1u);
}

TEST_F(Serial, ALoginRestartsTheSessionAndTheOldOneIsCleanedUp) {
  startBound();
  TestClient alice = flowClient("alice", "right");
  TestClient b = board();
  smallSession(b, 256, "");
  msg::ChanAdd add;
  add.tag = 1;
  add.kind = static_cast<uint8_t>(ChannelKind::streaming);
  add.short_name = "analog";
  add.props = Variant(Variant::Map{});
  ASSERT_TRUE(b.send(add));
  auto added = as<msg::EvChanAdded>(alice.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(added);
  // The board restarts mid-frame, then logs in again: a board starts with a delimiter, so that
  // the frame cut short ends there.
  ASSERT_TRUE(b.sendLineBytes("\x09partial"));
  TestClient again = board();
  ASSERT_TRUE(again.sendLineBytes(std::string(1, '\0')));
  auto ok = again.login("", "");
  ASSERT_TRUE(ok) << ok.error().message;
  auto removed = as<msg::EvChanRemoved>(alice.waitFor(Code::ev_chan_removed));
  ASSERT_TRUE(removed);
  EXPECT_EQ(removed->chan_id, added->info.id);
  EXPECT_EQ(line().line.sessions, 2u);
  EXPECT_NE(ok->connection_id, 0u);
}

TEST_F(Serial, AProtocolErrorEndsTheSessionNotThePort) {
  startBound();
  TestClient b = board();
  ASSERT_TRUE(b.login("", ""));
  test::LogCapture log;
  ASSERT_TRUE(b.send(msg::EvDropped{1, 1}));  // a hub-to-satellite code
  ASSERT_TRUE(eventually([&] { return log.sawTag("FLOW-PROTOCOL"); }));
  ASSERT_TRUE(eventually([&] { return !line().in_session; }));
  // Anything but a LOGIN is now answered not_logged_in.
  auto r = b.call(msg::Ping{{"x"}});
  ASSERT_TRUE(r);
  auto err = as<msg::ReplyError>(r);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::not_logged_in));
  TestClient again = board();
  ASSERT_TRUE(again.login("", ""));
  EXPECT_TRUE(line().open);
}

TEST_F(Serial, AnUnboundPortTakesABoardsOwnAccountButNeverTheDevelopmentOne) {
  pty_ = Pty::open();
  startWith(pty_.slave, "");
  TestClient b = board();
  EXPECT_FALSE(b.login("guest", "password"));
  TestClient b2 = board();
  EXPECT_FALSE(b2.login("alice", "wrong"));
  TestClient b3 = board();
  auto ok = b3.login("alice", "right");
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->user, "alice");
}

TEST_F(Serial, ADeviceNotPluggedInYetIsListedAwayAndOpenedWhenItAppears) {
  const auto link = dir_.path() / "ttyLATE";
  startWith(link.string(), "board");
  const SerialCounters before = line();
  EXPECT_EQ(before.device, link.string());
  EXPECT_FALSE(before.open);
  plugIn(link);
}

TEST_F(Serial, ADeviceThatGoesAwayIsReopenedWhenItComesBack) {
  // The config names a glob; the device is a link to the current pseudo-terminal.
  pty_ = Pty::open();
  const auto link = dir_.path() / "ttyBOARD0";
  std::filesystem::create_symlink(pty_.slave, link);
  test::LogCapture log;
  startWith((dir_.path() / "ttyBOARD*").string(), "board");
  {
    TestClient b = board();
    ASSERT_TRUE(b.login("", ""));
  }
  // Unplugged: the line ends; the hub waits for the device.
  ::close(pty_.master);
  std::filesystem::remove(link);
  ASSERT_TRUE(eventually([&] { return log.sawTag("SERIAL-LOST"); }));
  ASSERT_TRUE(eventually([&] { return !line().open; }));
  // Plugged again (another pseudo-terminal behind the same name).
  plugIn(link);
}

}  // namespace
}  // namespace skr::test
