// SPDX-License-Identifier: Apache-2.0
// Before login a connection is held short: frames of 4096 bytes at most, and failed logins slow
// down the next ones per user name and per source (login_throttle.h).
#include "families/session/login_throttle.h"
#include "flow_fixture.h"
#include "log_capture.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/clock.h>

#include <gtest/gtest.h>

namespace skr::flow {
namespace {

using test::TestClient;

TEST(LoginThrottle, DelaysDoubleAndASuccessForgets) {
  LoginThrottle t;
  const Nanos t0 = 1000 * kNsPerSec;
  EXPECT_EQ(t.wait("alice", "tcp:10.0.0.1", t0), 0);
  t.failed("alice", "tcp:10.0.0.1", t0);
  EXPECT_EQ(t.wait("alice", "tcp:10.0.0.9", t0), LoginThrottle::kFirstDelay);  // by name
  EXPECT_EQ(t.wait("bob", "tcp:10.0.0.1", t0), LoginThrottle::kFirstDelay);    // by source
  EXPECT_EQ(t.wait("bob", "tcp:10.0.0.9", t0), 0);
  t.failed("alice", "tcp:10.0.0.1", t0);
  EXPECT_EQ(t.wait("alice", "x", t0), 2 * LoginThrottle::kFirstDelay);
  for (int i = 0; i < 20; ++i) t.failed("alice", "tcp:10.0.0.1", t0);
  EXPECT_EQ(t.wait("alice", "x", t0), LoginThrottle::kMaxDelay);
  EXPECT_EQ(t.wait("alice", "x", t0 + LoginThrottle::kMaxDelay), 0);
  t.succeeded("alice", "tcp:10.0.0.1");
  EXPECT_EQ(t.wait("alice", "tcp:10.0.0.1", t0), 0);
  // Ten idle minutes forget a name: its next failure starts over.
  t.failed("carol", "", t0);
  t.failed("carol", "", t0);
  const Nanos later = t0 + LoginThrottle::kForgetAfter + kNsPerSec;
  t.failed("carol", "", later);
  EXPECT_EQ(t.wait("carol", "", later), LoginThrottle::kFirstDelay);
}

TEST(LoginThrottle, AFloodOfNamesStaysBounded) {
  LoginThrottle t;
  Nanos now = kNsPerSec;
  for (int i = 0; i < 50000; ++i) t.failed("user" + std::to_string(i), "tcp:10.0.0.1", now += 1000);
  EXPECT_LE(t.size(), LoginThrottle::kMaxEntries);
  EXPECT_GT(t.wait("x", "tcp:10.0.0.1", now), 0);  // the source itself is remembered
}

class LoginLimits : public test::FlowFixture {};

TEST_F(LoginLimits, ALargeFrameBeforeLoginClosesOnlyThatConnection) {
  startHub();
  TestClient ok = flowClient();
  TestClient bad = connect();
  // A frame announcing 1 MB (under max_frame_bytes) before login: closed at once, without
  // waiting for (or allocating) the body; the login timeout (5 s) would close it only later.
  std::string frame;
  appendHeader(frame, Code::login, 1'000'000);
  frame.append(10, 'x');
  ASSERT_TRUE(bad.sendRaw(frame));
  EXPECT_TRUE(bad.closedByPeer(2000));
  // After login the server's max_frame_bytes applies: 64 KiB of payload is fine.
  TestClient pub = flowClient();
  const uint16_t id = addChannel(pub, "big");
  ASSERT_TRUE(ok.send(msg::Subscribe{1, id}));
  ASSERT_TRUE(pub.waitFor(Code::ev_start_publish));
  const std::string big(64 * 1024, 'y');
  ASSERT_TRUE(pub.send(msg::Publish{id, msg::Rest{big}}));
  auto data = test::as<msg::EvData>(ok.waitFor(Code::ev_data));
  ASSERT_TRUE(data);
  EXPECT_EQ(data->payload.bytes.size(), 64u * 1024);
}

TEST_F(LoginLimits, FailedLoginsHoldBackTheNextOnes) {
  auto o = defaults();
  o.users_file = dir_.path() / "users.json";
  auto users = UsersFile::load(o.users_file);
  ASSERT_TRUE(users);
  ASSERT_TRUE(users->add("alice", "right"));
  ASSERT_TRUE(users->save());
  ASSERT_TRUE(startHub(o));
  test::LogCapture log;
  {
    TestClient c = connect();
    EXPECT_FALSE(c.login("alice", "wrong"));
  }
  EXPECT_FALSE(log.sawTag("FLOW-LOGIN-THROTTLED"));  // the first attempt did not wait
  {
    TestClient c = connect();
    EXPECT_FALSE(c.login("alice", "wrong"));  // waited for the first failure's delay
  }
  EXPECT_TRUE(log.sawTag("FLOW-LOGIN-THROTTLED"));
  // The third attempt waits (0.5 s after two failures), then succeeds: throttled, not refused.
  TestClient c = connect();
  const Nanos start = monotonicNs();
  auto r = c.login("alice", "right");
  EXPECT_TRUE(r) << (r ? "" : r.error().message);
  EXPECT_GE(monotonicNs() - start, LoginThrottle::kFirstDelay);  // 0.5 s less the round trips
  // The success forgot the name and the source: the next login is not held back.
  const auto throttled = [&log] {
    int n = 0;
    for (const auto& l : log.lines()) n += l.rfind("FLOW-LOGIN-THROTTLED ", 0) == 0 ? 1 : 0;
    return n;
  };
  const int before = throttled();
  TestClient again = connect();
  EXPECT_TRUE(again.login("alice", "right"));
  EXPECT_EQ(throttled(), before);
}

}  // namespace
}  // namespace skr::flow
