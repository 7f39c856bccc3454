// SPDX-License-Identifier: Apache-2.0
// The line framing on a simulated Arduino Uno (sketches/line_echo: it sends "BOOT" at start and
// echoes every frame it receives whole): the sketch built with the Arduino core, simavr_runner
// (resets from the command line and from a signal, several boards at once) and line_relay
// (noise, unplugging).
#include "sim_board.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <thread>

namespace {

using namespace skr::boards::test;
using skr::test::TempDir;

const Bytes kBoot = {'B', 'O', 'O', 'T'};

Bytes text(const std::string& s) {
  return Bytes(s.begin(), s.end());
}

// The echo sketch's counters, asked with a frame "?" (a few tries on a noisy line).
std::optional<skr_line_stats> boardStats(LinePort& port) {
  for (int attempt = 0; attempt < 5; ++attempt) {
    port.send(text("?"));
    for (auto f = port.next(1000); f; f = port.next(1000)) {
      if (f->size() != 21 || (*f)[0] != 'S') continue;  // an echo still on its way
      auto u32 = [&](size_t at) {
        return uint32_t((*f)[at]) | uint32_t((*f)[at + 1]) << 8 | uint32_t((*f)[at + 2]) << 16 |
               uint32_t((*f)[at + 3]) << 24;
      };
      return skr_line_stats{u32(1), u32(5), u32(9), u32(13), u32(17)};
    }
  }
  return std::nullopt;
}

uint32_t dropped(const skr_line_stats& s) {
  return s.bad_check + s.bad_framing + s.bad_version + s.too_long;
}

TEST(BoardLineEcho, EchoesFramesOfEveryShape) {
  TempDir dir("skrobot-board");
  SimBoard board(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path());
  ASSERT_FALSE(board.pty().empty()) << board.output();
  LinePort port(board.pty());
  ASSERT_TRUE(port.ok());
  EXPECT_EQ(port.next(), kBoot);

  std::mt19937 rng(3);
  for (size_t size : {1u, 2u, 9u, 63u, 64u, 65u, 127u, 128u}) {
    for (int fill = 0; fill < 3; ++fill) {
      Bytes frame(size);
      for (auto& b : frame) b = fill == 0 ? 0 : fill == 1 ? 0xFF : uint8_t(rng());
      if (size == 1 && frame[0] == '?') frame[0] = 0;
      ASSERT_TRUE(port.send(frame));
      EXPECT_EQ(port.next(), frame) << "size " << size << " fill " << fill;
    }
  }
  // One byte more than the sketch's buffer: dropped and counted on the board.
  ASSERT_TRUE(port.send(Bytes(129, 0x55)));
  const auto stats = boardStats(port);
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->too_long, 1u);
  EXPECT_EQ(stats->frames, 8u * 3u + 1u);  // the "?" included
  EXPECT_EQ(dropped(port.stats()), 0u);
  EXPECT_EQ(board.stop(), 0) << board.output();
  EXPECT_NE(board.output().find("SIM simulated "), std::string::npos) << board.output();
}

TEST(BoardLineEcho, ResetMidFrameStartsAgain) {
  TempDir dir("skrobot-board");
  SimBoard board(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path());
  LinePort port(board.pty());
  ASSERT_TRUE(port.ok()) << board.output();
  ASSERT_EQ(port.next(), kBoot);
  ASSERT_TRUE(port.send(text("before")));
  ASSERT_EQ(port.next(), text("before"));

  // Half a frame, then the board restarts: it says BOOT again, the other half is one bad frame
  // to the new board, and what follows is echoed. (The board takes the half in 2 ms of simulated
  // time; when the simulator is slower than the 100 ms given, the first half reaches the new
  // board instead, and the whole frame comes back: both are counted right.)
  const Bytes half(40, 0x33);
  const Bytes line = LinePort::encode(half);
  ASSERT_TRUE(port.write(Bytes(line.begin(), line.begin() + 20)));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  board.reset();
  EXPECT_EQ(port.next(), kBoot);
  ASSERT_TRUE(port.write(Bytes(line.begin() + 20, line.end())));
  ASSERT_TRUE(port.send(text("after")));
  auto f = port.next();
  const bool whole = f == half;
  if (whole) f = port.next();
  EXPECT_EQ(f, text("after"));
  const auto stats = boardStats(port);
  ASSERT_TRUE(stats);
  EXPECT_EQ(dropped(*stats), whole ? 0u : 1u);
  EXPECT_EQ(stats->frames, whole ? 3u : 2u);  // "after" and "?": the counters started again
  board.stop();
  EXPECT_NE(board.output().find("resets 1"), std::string::npos) << board.output();
}

// --reset-at-ms, and --limit-ms: the runner ends by itself after that much simulated time.
TEST(BoardLineEcho, ResetAndEndAtASimulatedTime) {
  TempDir dir("skrobot-board");
  SimBoard board(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path(),
                 {"--realtime", "--reset-at-ms", "300", "--limit-ms", "600"});
  LinePort port(board.pty());
  ASSERT_TRUE(port.ok()) << board.output();
  EXPECT_EQ(port.next(), kBoot);
  EXPECT_EQ(port.next(), kBoot);
  EXPECT_TRUE(skr::test::eventually([&] { return !board.running(); }, 10000));
  EXPECT_NE(board.output().find("SIM simulated 600.0 ms"), std::string::npos) << board.output();
  EXPECT_NE(board.output().find("resets 1"), std::string::npos) << board.output();
}

// The hub closes a port and opens it again (a protocol error, a restart): the board's terminal
// stays usable.
TEST(BoardLineEcho, PortClosedAndOpenedAgain) {
  TempDir dir("skrobot-board");
  SimBoard board(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path());
  {
    LinePort port(board.pty());
    ASSERT_TRUE(port.ok()) << board.output();
    EXPECT_EQ(port.next(), kBoot);
  }
  LinePort port(board.pty());
  ASSERT_TRUE(port.ok());
  ASSERT_TRUE(port.send(text("again")));
  EXPECT_EQ(port.next(), text("again"));
  EXPECT_TRUE(board.running());
}

TEST(BoardLineEcho, SeveralBoardsAtOnce) {
  TempDir dir("skrobot-board");
  SimBoard a(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path());
  SimBoard b(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path());
  ASSERT_NE(a.pty(), b.pty());
  LinePort pa(a.pty()), pb(b.pty());
  ASSERT_TRUE(pa.ok() && pb.ok());
  EXPECT_EQ(pa.next(), kBoot);
  EXPECT_EQ(pb.next(), kBoot);
  ASSERT_TRUE(pa.send(text("to a")));
  ASSERT_TRUE(pb.send(text("to b")));
  EXPECT_EQ(pa.next(), text("to a"));
  EXPECT_EQ(pb.next(), text("to b"));
}

// Through the relay at 115200 baud with an error every ~330 bytes in each direction: frames the
// noise hit are dropped and counted at both ends, the others come back intact.
TEST(BoardLineEcho, NoisyLineDropsAndCountsBadFrames) {
  TempDir dir("skrobot-board");
  SimBoard board(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path());
  LineRelay relay(LINE_RELAY_BIN, board.pty(), dir.path(),
                  {"--baud", "115200", "--seed", "7", "--error-rate", "3e-3"});
  ASSERT_FALSE(relay.pty().empty()) << relay.output();
  LinePort port(relay.pty());
  ASSERT_TRUE(port.ok());

  const int kFrames = 120, kWindow = 4;
  std::vector<Bytes> sent;
  int echoed = 0;
  for (int i = 0; i < kFrames; i += kWindow) {
    for (int j = i; j < i + kWindow; ++j) {
      Bytes frame(24);
      for (size_t k = 0; k < frame.size(); ++k) frame[k] = uint8_t(j * 7 + k);
      frame[0] = 'F';
      frame[1] = uint8_t(j);
      sent.push_back(frame);
      ASSERT_TRUE(port.send(frame));
    }
    for (int got = 0; got < kWindow;) {
      const auto f = port.next(150);
      if (!f) break;
      if (*f == kBoot) continue;
      ASSERT_EQ(f->size(), 24u);
      ASSERT_LT((*f)[1], sent.size());
      EXPECT_EQ(*f, sent[(*f)[1]]) << "an echo that passed the check is intact";
      ++echoed;
      ++got;
    }
  }
  std::printf("echoed %d of %d; bad frames: %u at the test's end\n", echoed, kFrames,
              dropped(port.stats()));
  EXPECT_GT(echoed, kFrames / 2);
  EXPECT_LT(echoed, kFrames);
  EXPECT_GT(dropped(port.stats()), 0u);
  const auto stats = boardStats(port);
  ASSERT_TRUE(stats);
  std::printf("board: %u frames, %u bad frames\n", stats->frames, dropped(*stats));
  EXPECT_GT(dropped(*stats), 0u);
  EXPECT_GT(stats->frames, uint32_t(echoed) / 2);
  EXPECT_EQ(relay.stop(), 0);
  const std::string out = relay.output();
  EXPECT_NE(out.find("RELAY to_board bytes "), std::string::npos) << out;
  EXPECT_EQ(out.find("dropped 0 flipped 0 inserted 0"), std::string::npos) << out;
}

// The relay's terminal goes away and comes back under a new name, which its link follows.
TEST(BoardLineEcho, RelayUnplugsAndReplugs) {
  TempDir dir("skrobot-board");
  SimBoard board(SIMAVR_RUNNER_BIN, LINE_ECHO_ELF, dir.path());
  const std::string link = (dir.path() / "ttyBOARD").string();
  LineRelay relay(LINE_RELAY_BIN, board.pty(), dir.path(),
                  {"--unplug-at-ms", "600", "--replug-after-ms", "300", "--link", link});
  const std::string first = relay.pty();
  ASSERT_FALSE(first.empty()) << relay.output();
  {
    LinePort port(link);
    ASSERT_TRUE(port.ok());
    ASSERT_TRUE(port.send(text("one")));
    for (auto f = port.next(); f && *f != text("one"); f = port.next()) {
    }
    EXPECT_FALSE(port.next(3000));
    EXPECT_TRUE(port.hungUp());
  }
  ASSERT_TRUE(relay.waitPty(2)) << relay.output();
  ASSERT_TRUE(skr::test::eventually(
      [&] {
        std::error_code ec;
        return fs::read_symlink(link, ec) == relay.pty();
      },
      2000));
  LinePort port(link);
  ASSERT_TRUE(port.ok());
  ASSERT_TRUE(port.send(text("two")));
  EXPECT_EQ(port.next(), text("two"));
  EXPECT_EQ(relay.stop(), 0);
  EXPECT_NE(relay.output().find("unplugs 1"), std::string::npos) << relay.output();
}

}  // namespace
