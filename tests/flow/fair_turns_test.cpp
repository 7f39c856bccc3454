// SPDX-License-Identifier: Apache-2.0
// Fair turns (docs/internals.md): one connection's flood of frames, read at once, is handled a
// budget of frames per loop turn, so another connection's requests are answered while the flood
// is still being handled, not after all that was read.
#include "flow_fixture.h"

#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>

namespace skr::test {
namespace {

using flow::Code;
namespace msg = flow::msg;

class FairTurns : public FlowFixture {};

TEST_F(FairTurns, AFloodOfFramesDoesNotHoldAnotherConnectionsRequests) {
  startHub();
  TestClient flooder = flowClient();
  TestClient prober = syncClient();
  const uint16_t chan = addChannel(flooder, "flood");
  ASSERT_EQ(prober.call(msg::PollRegister{chan})->kind(), Code::reply_ok);
  // A million small PUBLISH frames (about 13 MB) written from a thread: the hub reads a socket
  // up to 2 MB per readiness (libuv reads 64 KiB 32 times), some 150,000 of these.
  constexpr int kFlood = 1000000;
  std::string flood;
  for (int i = 0; i < kFlood; ++i) {
    ASSERT_TRUE(flow::encode(flood, msg::Publish{chan, msg::Rest{"x"}}));
  }
  std::thread writer([&] { EXPECT_TRUE(flooder.sendRaw(flood)); });
  // Another connection's requests meanwhile, back to back, until the flood is handled: each
  // answer says how many of the flood's messages the hub had handled (POLL_FETCH's sequence).
  uint64_t previous = 0, most = 0;
  int asked = 0;
  for (;;) {
    auto fetched = as<msg::PollData>(prober.call(msg::PollFetch{chan}));
    ASSERT_TRUE(fetched);
    ++asked;
    if (previous > 0) most = std::max(most, fetched->seq - previous);
    previous = fetched->seq;
    if (fetched->seq >= static_cast<uint64_t>(kFlood)) break;
  }
  writer.join();
  const auto s = stats();
  EXPECT_GT(s.turns_yielded, 0u);
  // Without turns a request waits for the rest of a whole read (some 150,000 messages): a handful
  // are answered during the flood (7 to 15 here). With them, one a turn or two (a turn is 4096
  // of these frames): about 125.
  EXPECT_GE(asked, 50) << "at most " << most << " messages between two answers; " << s.turns_yielded
                       << " turns yielded";
  std::printf(
      "fair turns: %d requests during the flood; at most %llu of its messages between "
      "two answers\n",
      asked, static_cast<unsigned long long>(most));
}

}  // namespace
}  // namespace skr::test
