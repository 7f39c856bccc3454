// SPDX-License-Identifier: Apache-2.0
// The board's session (satellite/mcu/src/skr_flow.h) against a scripted hub on an in-memory line:
// the hub reads what the board sent with the runtime's own codec (messages.h, codec.h) and answers
// with frames encoded by it, so the board and the hub's code agree on every layout.
#include "skr_codes.h"
#include "skr_flow.h"

#include <gtest/gtest.h>
#include <skrobot/runtime/flow/bytes.h>
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/messages.h>

#include <cstring>
#include <deque>
#include <string>
#include <vector>

namespace {

using namespace skr::flow;

struct Hub {
  std::deque<uint8_t> to_board;
  std::vector<uint8_t> rx_buf = std::vector<uint8_t>(4096 + SKR_LINE_RX_EXTRA);
  skr_line_rx rx{};
  std::deque<std::string> sent;  // frames the board sent, whole (length and code included)
  uint32_t clock = 1000;

  Hub() { skr_line_rx_init(&rx, rx_buf.data(), rx_buf.size()); }

  static int read(void* ctx) {
    auto* h = static_cast<Hub*>(ctx);
    if (h->to_board.empty()) return -1;
    const int b = h->to_board.front();
    h->to_board.pop_front();
    return b;
  }
  static void write(void* ctx, const uint8_t* data, size_t n) {
    auto* h = static_cast<Hub*>(ctx);
    for (size_t i = 0; i < n; ++i) {
      if (const size_t m = skr_line_rx_byte(&h->rx, data[i]); m > 0) {
        h->sent.emplace_back(reinterpret_cast<const char*>(skr_line_rx_frame(&h->rx)), m);
      }
    }
  }
  static uint32_t millis(void* ctx) { return static_cast<Hub*>(ctx)->clock; }

  void raw(const std::string& bytes) {
    to_board.insert(to_board.end(), bytes.begin(), bytes.end());
  }
  void frame(const std::string& f) {
    std::vector<uint8_t> line(f.size() + SKR_LINE_OVERHEAD(f.size()));
    const size_t n = skr_line_encode(reinterpret_cast<const uint8_t*>(f.data()), f.size(),
                                     line.data(), line.size());
    to_board.insert(to_board.end(), line.begin(), line.begin() + n);
  }
  template <class M>
  void send(const M& m) {
    std::string f;
    ASSERT_TRUE(encode(f, m));
    frame(f);
  }

  // The next frame the board sent, which must have `code`; its body.
  std::string next(uint8_t code) {
    if (sent.empty()) {
      ADD_FAILURE() << "the board sent nothing; expected " << codeName(code);
      return {};
    }
    std::string f = sent.front();
    sent.pop_front();
    EXPECT_GE(f.size(), 5u);
    uint32_t len = 0;
    std::memcpy(&len, f.data(), 4);
    EXPECT_EQ(len, f.size() - 4);
    EXPECT_EQ(static_cast<uint8_t>(f[4]), code)
        << "got " << codeName(static_cast<uint8_t>(f[4])) << ", expected " << codeName(code);
    return f.substr(5);
  }
  // A payload (msg::Rest) points into its frame's body: the bodies stay here.
  std::deque<std::string> bodies;
  template <class M>
  M expect() {
    bodies.push_back(next(static_cast<uint8_t>(M::code)));
    auto m = decode<M>(bodies.back());
    EXPECT_TRUE(m.ok()) << (m.ok() ? "" : m.error().message);
    return m.ok() ? *m : M{};
  }
};

msg::EvChanAdded added(uint32_t tag, uint16_t id, uint8_t kind, const std::string& name) {
  msg::EvChanAdded e;
  e.tag = tag;
  e.info.id = id;
  e.info.hash = 0x1122334455667788ull + id;
  e.info.kind = kind;
  e.info.name = name;
  e.info.owner = name.substr(0, name.find('.'));
  e.info.mime = "application/octet-stream";
  e.info.props = Variant::Map{{"rate_hz", Variant(int64_t{50})}};
  return e;
}

std::string errorFrame(uint16_t error) {
  std::string f;
  EXPECT_TRUE(encode(f, msg::ReplyError{.error = error, .message = "no session"}));
  return f;
}

// What the callbacks saw.
struct Seen {
  std::vector<std::string> data;
  std::vector<std::pair<uint32_t, uint32_t>> pulses;
  std::vector<std::string> commands;
};

void onData(void* user, const uint8_t* p, size_t n) {
  static_cast<Seen*>(user)->data.emplace_back(reinterpret_cast<const char*>(p), n);
}
void onPulse(void* user, uint32_t seq, uint32_t dropped) {
  static_cast<Seen*>(user)->pulses.emplace_back(seq, dropped);
}
// read_adc: answers its int64 argument plus 1000; set_pwm: answers the string "ok"; else nothing.
void onService(void* user, const char* cmd, size_t cmd_n, const uint8_t* value, size_t value_n,
               skr_out* answer) {
  const std::string c(cmd, cmd_n);
  static_cast<Seen*>(user)->commands.push_back(c);
  int64_t v = 0;
  if (c == "read_adc" && skr_value_int64(value, value_n, &v)) skr_put_int64(answer, v + 1000);
  if (c == "set_pwm") skr_put_string(answer, "ok", 2);
}

// The board's side of the session up to its first CHAN_ADD (GO_ASYNC answered).
void goAsync(Hub& hub, skr_flow& f) {
  skr_poll(&f);
  hub.expect<msg::Login>();
  hub.send(
      msg::LoginOk{.connection_id = 3, .app_name = "hub", .user = "robot", .current_db = "robot"});
  skr_poll(&f);
  hub.expect<msg::SessionLimits>();
  hub.send(msg::Ack{});
  skr_poll(&f);
  hub.expect<msg::GoAsync>();
  hub.send(msg::Ack{});
  skr_poll(&f);
}

class Board : public ::testing::Test {
 protected:
  void SetUp() override {
    io.ctx = &hub;
    io.read = Hub::read;
    io.write = Hub::write;
    io.millis = Hub::millis;
    skr_init(&f, &io, "robot", "secret", "uno");
    analog = skr_channel(&f, "analog", "application/x-u16le");
    service = skr_service_add(&f, "board", onService, &seen);
    ASSERT_EQ(skr_subscribe(&f, "guest.setpoint", onData, &seen), SKR_OK);
    ASSERT_EQ(skr_follow(&f, "robot.pulse", onPulse, &seen), SKR_OK);
  }

  // Takes the board from its LOGIN to a flow with its channels' ids (analog 7, board 8).
  void connect() {
    goAsync(hub, f);
    ASSERT_TRUE(skr_connected(&f));
    const auto a = hub.expect<msg::ChanAdd>();
    ASSERT_TRUE(hub.sent.empty()) << "one CHAN_ADD at a time";
    hub.send(added(a.tag, 7, a.kind, "robot.analog"));
    skr_poll(&f);
    const auto b = hub.expect<msg::ChanAdd>();
    hub.send(added(b.tag, 8, b.kind, "robot.board"));
    skr_poll(&f);
    ASSERT_TRUE(skr_channel_ready(&f, analog));
  }

  Hub hub;
  skr_io io{};
  skr_flow f{};
  Seen seen;
  int analog = -1, service = -1;
};

TEST_F(Board, LogsInWithLimitsThenGoesAsyncAndAddsItsChannels) {
  skr_poll(&f);
  const auto login = hub.expect<msg::Login>();
  EXPECT_EQ(login.major, 1);
  EXPECT_EQ(login.minor, kProtocolMinor);
  EXPECT_GE(login.minor, 12);
  EXPECT_EQ(login.value_encoding, 0);
  EXPECT_EQ(login.user, "robot");
  EXPECT_EQ(login.password, "secret");
  EXPECT_EQ(login.client_name, "uno");
  skr_poll(&f);
  EXPECT_TRUE(hub.sent.empty()) << "one request at a time";
  hub.send(
      msg::LoginOk{.connection_id = 3, .app_name = "hub", .user = "robot", .current_db = "robot"});
  skr_poll(&f);
  const auto l = hub.expect<msg::SessionLimits>();
  EXPECT_EQ(l.max_frame, SKR_RX_MAX);
  EXPECT_EQ(l.events, 0u);
  EXPECT_EQ(l.watch, "guest.setpoint robot.pulse");
  hub.send(msg::Ack{});
  skr_poll(&f);
  hub.expect<msg::GoAsync>();
  EXPECT_FALSE(skr_connected(&f));
  hub.send(msg::Ack{});
  skr_poll(&f);
  EXPECT_TRUE(skr_connected(&f));
  const auto a = hub.expect<msg::ChanAdd>();
  EXPECT_EQ(a.kind, 1);
  EXPECT_EQ(a.short_name, "analog");
  EXPECT_EQ(a.mime, "application/x-u16le");
  EXPECT_TRUE(a.props.isNull());
  // One at a time: the service's CHAN_ADD waits for the answer to the first (at 1,000,000 baud
  // the answers to both, sent at once, overflowed an Uno's receive buffer).
  EXPECT_TRUE(hub.sent.empty()) << "a second CHAN_ADD before the first was answered";
  hub.send(added(a.tag, 7, a.kind, "robot.analog"));
  skr_poll(&f);
  const auto s = hub.expect<msg::ChanAdd>();
  EXPECT_EQ(s.kind, 2);
  EXPECT_EQ(s.short_name, "board");
  EXPECT_NE(a.tag, s.tag);
  EXPECT_TRUE(hub.sent.empty());
  EXPECT_EQ(skr_get_stats(&f)->logins, 1u);
}

TEST_F(Board, LogsInAgainWhenAChannelsAnswerIsLost) {
  goAsync(hub, f);
  const auto a = hub.expect<msg::ChanAdd>();
  // Its EV_CHAN_ADDED never comes (lost on the line); the probes' answers keep the hub alive.
  for (uint32_t t = 0; t < SKR_REPLY_TIMEOUT_MS; t += 500) {
    hub.clock += 500;
    hub.send(msg::EvTimeProbe{.tag = 0x400, .t1 = 1, .t2 = 1, .t3 = 2});
    skr_poll(&f);
  }
  EXPECT_FALSE(skr_connected(&f)) << "a channel without its id, and the session goes on";
  hub.sent.clear();
  hub.clock += SKR_BACKOFF_MS;
  skr_poll(&f);
  hub.expect<msg::Login>();
  EXPECT_EQ(skr_get_stats(&f)->logins, 2u);
  (void)a;
}

TEST_F(Board, ARefusedChannelLetsTheNextOneGo) {
  goAsync(hub, f);
  const auto a = hub.expect<msg::ChanAdd>();
  hub.send(msg::EvError{
      .command = SKR_CODE_CHAN_ADD, .tag = a.tag, .chan_id = 0, .error = 6, .message = "exists"});
  skr_poll(&f);
  EXPECT_EQ(hub.expect<msg::ChanAdd>().short_name, "board");
  EXPECT_FALSE(skr_channel_ready(&f, analog));
  EXPECT_EQ(skr_get_stats(&f)->errors, 1u);
}

TEST_F(Board, LearnsChannelIdsFromTagsAndPublishesOnlyThen) {
  uint8_t two[2] = {0x34, 0x12};
  EXPECT_EQ(skr_publish(&f, analog, two, 2), SKR_OFFLINE);
  connect();
  // Someone else's channel of the same short name (tag 0) changes nothing.
  hub.send(added(0, 99, 1, "other.analog"));
  skr_poll(&f);
  EXPECT_EQ(skr_publish(&f, analog, two, 2), SKR_OK);
  const auto p = hub.expect<msg::Publish>();
  EXPECT_EQ(p.chan_id, 7);
  EXPECT_EQ(p.payload.bytes, std::string("\x34\x12", 2));
  EXPECT_EQ(skr_publish(&f, 5, two, 2), SKR_BAD_HANDLE);
  std::vector<uint8_t> big(SKR_TX_MAX);
  EXPECT_EQ(skr_publish(&f, analog, big.data(), big.size()), SKR_TOO_BIG);
  EXPECT_TRUE(hub.sent.empty());
  EXPECT_EQ(skr_get_stats(&f)->sent_dropped, 2u);
}

TEST_F(Board, SubscribesWhenAWatchedChannelAppearsAndGetsItsData) {
  connect();
  hub.send(added(0, 40, 1, "guest.other"));     // not watched
  hub.send(added(0, 41, 4, "guest.setpoint"));  // watched, but not a streaming channel
  hub.send(added(0, 42, 1, "guest.setpoint"));
  hub.send(added(0, 43, 4, "robot.pulse"));
  skr_poll(&f);
  const auto s = hub.expect<msg::Subscribe>();
  EXPECT_EQ(s.chan_id, 42);
  const auto follow = hub.expect<msg::SyncFollow>();
  EXPECT_EQ(follow.chan_id, 43);
  EXPECT_EQ(follow.every, 1u);
  EXPECT_TRUE(hub.sent.empty());

  hub.send(msg::EvData{.chan_id = 42, .payload = {"\x01\x02\x03"}});
  hub.send(msg::EvData{.chan_id = 40, .payload = {"nope"}});
  hub.send(msg::EvData{.chan_id = 42, .payload = {""}});
  skr_poll(&f);
  ASSERT_EQ(seen.data.size(), 2u);
  EXPECT_EQ(seen.data[0], "\x01\x02\x03");
  EXPECT_EQ(seen.data[1], "");

  // Removed: its data no longer reaches the callback; added again: subscribed again.
  hub.send(msg::EvChanRemoved{.chan_id = 42, .hash = 1, .name = "guest.setpoint"});
  hub.send(msg::EvData{.chan_id = 42, .payload = {"late"}});
  hub.send(added(0, 44, 1, "guest.setpoint"));
  skr_poll(&f);
  EXPECT_EQ(seen.data.size(), 2u);
  EXPECT_EQ(hub.expect<msg::Subscribe>().chan_id, 44);
}

TEST_F(Board, AnswersServiceRequests) {
  connect();
  for (const char* cmd : {"read_adc", "set_pwm", "unknown"}) {
    hub.send(msg::EvServiceRequest{.chan_id = 8,
                                   .request = 0xA1B2C3D4E5F60718ull,
                                   .command = cmd,
                                   .requester = "guest",
                                   .value = Variant(int64_t{-5})});
  }
  hub.send(msg::EvServiceRequest{.chan_id = 7,
                                 .request = 1,
                                 .command = "read_adc",
                                 .requester = "guest",
                                 .value = {}});  // not a service
  skr_poll(&f);
  EXPECT_EQ(seen.commands, (std::vector<std::string>{"read_adc", "set_pwm", "unknown"}));
  const auto r1 = hub.expect<msg::ServiceResponse>();
  EXPECT_EQ(r1.chan_id, 8);
  EXPECT_EQ(r1.request, 0xA1B2C3D4E5F60718ull);
  EXPECT_EQ(r1.value, Variant(int64_t{995}));
  EXPECT_EQ(hub.expect<msg::ServiceResponse>().value, Variant("ok"));
  EXPECT_TRUE(hub.expect<msg::ServiceResponse>().value.isNull());
  EXPECT_TRUE(hub.sent.empty());
}

TEST_F(Board, SetsVariablesOfItsFlow) {
  EXPECT_EQ(skr_var_set_int64(&f, "rate_hz", 50), SKR_OFFLINE);
  connect();
  EXPECT_EQ(skr_var_set_int64(&f, "rate_hz", -1234567890123ll), SKR_OK);
  EXPECT_EQ(skr_var_set_string(&f, "analog.unit", "mV"), SKR_OK);
  EXPECT_EQ(skr_var_set_float64(&f, "gain", 1.5), SKR_OK);
  auto a = hub.expect<msg::VarSetAsync>();
  EXPECT_EQ(a.key, "rate_hz");
  EXPECT_EQ(a.value, Variant(int64_t{-1234567890123ll}));
  auto b = hub.expect<msg::VarSetAsync>();
  EXPECT_EQ(b.key, "analog.unit");
  EXPECT_EQ(b.value, Variant("mV"));
  auto c = hub.expect<msg::VarSetAsync>();
  EXPECT_EQ(c.value, Variant(1.5));
}

// What skr_var_get answered: the values (binary Variants), "null" for a failed read.
void onValue(void* user, const uint8_t* value, size_t len) {
  static_cast<Seen*>(user)->data.push_back(
      value ? std::string(reinterpret_cast<const char*>(value), len) : std::string("null"));
}

TEST_F(Board, ReadsVariablesOneAtATime) {
  EXPECT_EQ(skr_var_get(&f, "robot", "gain", onValue, &seen), SKR_OFFLINE);
  connect();
  ASSERT_EQ(skr_var_get(&f, "robot", "gain", onValue, &seen), SKR_OK);
  EXPECT_EQ(skr_var_get(&f, "robot", "rate_hz", onValue, &seen), SKR_BUSY);
  const auto read = hub.expect<msg::DbRead>();
  EXPECT_EQ(read.db, "robot");
  EXPECT_EQ(read.what, uint8_t(msg::DbReadWhat::get));
  EXPECT_EQ(read.key, "gain");
  // An answer with another tag is not this read's.
  hub.send(msg::EvDbValue{read.tag + 1, Variant(int64_t{1})});
  hub.send(msg::EvDbValue{read.tag, Variant(int64_t{42})});
  skr_poll(&f);
  ASSERT_EQ(seen.data.size(), 1u);
  int64_t v = 0;
  ASSERT_TRUE(skr_value_int64(reinterpret_cast<const uint8_t*>(seen.data[0].data()),
                              seen.data[0].size(), &v));
  EXPECT_EQ(v, 42);
  // A refused read answers null; the next read may go.
  ASSERT_EQ(skr_var_get(&f, "robot", "missing", onValue, &seen), SKR_OK);
  const auto again = hub.expect<msg::DbRead>();
  EXPECT_NE(again.tag, read.tag);
  hub.send(msg::EvError{uint8_t(Code::db_read), again.tag, 0, uint16_t(ErrorCode::not_found),
                        "no such key"});
  skr_poll(&f);
  ASSERT_EQ(seen.data.size(), 2u);
  EXPECT_EQ(seen.data[1], "null");
  // A read pending when the session is lost gets no answer; the next session may read again.
  ASSERT_EQ(skr_var_get(&f, "robot", "gain", onValue, &seen), SKR_OK);
  hub.frame(errorFrame(uint16_t(ErrorCode::not_logged_in)));
  skr_poll(&f);
  EXPECT_FALSE(skr_connected(&f));
  EXPECT_EQ(seen.data.size(), 2u);
}

TEST_F(Board, ReadsValues) {
  std::string v;
  ByteWriter w(v);
  encodeVariant(Variant("text"), w);
  const char* s = nullptr;
  size_t n = 0;
  ASSERT_TRUE(skr_value_string(reinterpret_cast<const uint8_t*>(v.data()), v.size(), &s, &n));
  EXPECT_EQ(std::string(s, n), "text");
  EXPECT_FALSE(skr_value_string(reinterpret_cast<const uint8_t*>(v.data()), v.size() - 1, &s, &n));
  v.clear();
  encodeVariant(Variant(-2.25), w);
  double d = 0;
  int64_t i = 0;
  ASSERT_TRUE(skr_value_float64(reinterpret_cast<const uint8_t*>(v.data()), v.size(), &d));
  EXPECT_EQ(d, -2.25);
  EXPECT_FALSE(skr_value_int64(reinterpret_cast<const uint8_t*>(v.data()), v.size(), &i));
}

TEST_F(Board, FollowsTheSyncPulse) {
  connect();
  hub.send(added(0, 43, 4, "robot.pulse"));
  skr_poll(&f);
  hub.expect<msg::SyncFollow>();
  hub.send(msg::EvSyncPulse{.chan_id = 43, .seq = 1, .source_time_ns = 5, .dropped = 0});
  hub.send(msg::EvSyncPulse{.chan_id = 43, .seq = 4, .source_time_ns = 9, .dropped = 2});
  skr_poll(&f);
  EXPECT_EQ(seen.pulses, (std::vector<std::pair<uint32_t, uint32_t>>{{1, 0}, {4, 2}}));
  const auto d1 = hub.expect<msg::SyncDone>();
  EXPECT_EQ(d1.chan_id, 43);
  EXPECT_EQ(d1.seq, 1u);
  EXPECT_EQ(hub.expect<msg::SyncDone>().seq, 4u);
}

TEST_F(Board, LogsInAgainAfterNotLoggedIn) {
  connect();
  hub.frame(errorFrame(4));  // the hub restarted: it has no session for this board
  skr_poll(&f);
  EXPECT_FALSE(skr_connected(&f));
  EXPECT_EQ(skr_get_stats(&f)->last_error, SKR_ERROR_NOT_LOGGED_IN);
  uint8_t one = 1;
  EXPECT_EQ(skr_publish(&f, analog, &one, 1), SKR_OFFLINE);
  EXPECT_TRUE(hub.sent.empty());
  hub.clock += SKR_BACKOFF_MS;
  connect();  // from LOGIN again, ids learnt again
  EXPECT_EQ(skr_get_stats(&f)->logins, 2u);

  // An EV_ERROR not_logged_in on the flow does the same.
  msg::EvError e{.command = 0x44, .tag = 0, .chan_id = 7, .error = 4, .message = "who?"};
  hub.send(e);
  skr_poll(&f);
  EXPECT_FALSE(skr_connected(&f));
}

TEST_F(Board, LogsInAgainWhenTheHubFallsSilent) {
  connect();
  // A hub that answers the probes keeps the session.
  for (int i = 0; i < 5; ++i) {
    hub.clock += SKR_PROBE_MS;
    skr_poll(&f);
    const auto p = hub.expect<msg::TimeProbe>();
    EXPECT_EQ(p.t1, hub.clock);
    hub.send(msg::EvTimeProbe{.tag = p.tag, .t1 = p.t1, .t2 = 1, .t3 = 2});
    skr_poll(&f);
    ASSERT_TRUE(skr_connected(&f)) << i;
  }
  // A silent one is gone after SKR_SILENCE_MS.
  for (uint32_t t = 0; t < SKR_SILENCE_MS; t += 100) {
    hub.clock += 100;
    skr_poll(&f);
  }
  EXPECT_FALSE(skr_connected(&f));
  hub.sent.clear();
  hub.clock += SKR_BACKOFF_MS;
  skr_poll(&f);
  hub.expect<msg::Login>();
}

TEST_F(Board, RetriesAnUnansweredOrRefusedLoginWithABackOff) {
  skr_poll(&f);
  hub.expect<msg::Login>();
  hub.clock += SKR_REPLY_TIMEOUT_MS;
  skr_poll(&f);
  EXPECT_TRUE(hub.sent.empty());
  hub.clock += SKR_BACKOFF_MS;
  skr_poll(&f);
  hub.expect<msg::Login>();
  hub.frame(errorFrame(3));  // auth_failed
  skr_poll(&f);
  hub.clock += SKR_BACKOFF_MS;  // the back-off doubled
  skr_poll(&f);
  EXPECT_TRUE(hub.sent.empty());
  hub.clock += SKR_BACKOFF_MS;
  skr_poll(&f);
  hub.expect<msg::Login>();
  EXPECT_EQ(skr_get_stats(&f)->errors, 1u);
  EXPECT_EQ(skr_get_stats(&f)->logins, 3u);
}

TEST_F(Board, CountsAndIgnoresBadFrames) {
  connect();
  hub.send(added(0, 42, 1, "guest.setpoint"));
  skr_poll(&f);
  hub.expect<msg::Subscribe>();
  const skr_stats before = *skr_get_stats(&f);

  hub.frame(std::string("\x01\x00\x00", 3));                  // shorter than a header
  hub.frame(std::string("\x09\x00\x00\x00\x97\x2a\x00", 7));  // length says more than came
  hub.frame(std::string("\x02\x00\x00\x00\x97\x2a", 6));      // EV_DATA without its chan_id
  std::string cut;
  ASSERT_TRUE(encode(cut, added(0, 50, 1, "guest.setpoint")));
  cut.resize(cut.size() - 30);  // EV_CHAN_ADDED cut inside ChannelInfo (its mime)
  const uint32_t len = static_cast<uint32_t>(cut.size() - 4);
  std::memcpy(cut.data(), &len, 4);
  hub.frame(cut);
  std::string svc;
  ASSERT_TRUE(encode(
      svc,
      msg::EvServiceRequest{
          .chan_id = 8, .request = 1, .command = "read_adc", .requester = "guest", .value = {}}));
  svc.resize(svc.size() - 1);  // no value
  const uint32_t slen = static_cast<uint32_t>(svc.size() - 4);
  std::memcpy(svc.data(), &slen, 4);
  hub.frame(svc);
  skr_poll(&f);
  const skr_stats* s = skr_get_stats(&f);
  EXPECT_EQ(s->frames_bad - before.frames_bad, 5u);

  hub.frame(std::string(SKR_RX_MAX + 1, '\x05'));  // too long for the board
  hub.raw(std::string("\x07garbage\x00\x03\x01\x02\x00", 13));
  skr_poll(&f);
  s = skr_get_stats(&f);
  EXPECT_EQ(s->line.too_long - before.line.too_long, 1u);
  EXPECT_GE(
      s->line.bad_check + s->line.bad_framing - before.line.bad_check - before.line.bad_framing,
      2u);
  EXPECT_TRUE(seen.data.empty());
  EXPECT_TRUE(seen.commands.empty());
  EXPECT_TRUE(hub.sent.empty()) << "nothing answered, nothing subscribed";

  // The session goes on.
  EXPECT_TRUE(skr_connected(&f));
  hub.send(msg::EvData{.chan_id = 42, .payload = {"ok"}});
  skr_poll(&f);
  ASSERT_EQ(seen.data.size(), 1u);
  EXPECT_EQ(seen.data[0], "ok");
}

}  // namespace
