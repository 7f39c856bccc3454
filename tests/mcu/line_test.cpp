// SPDX-License-Identifier: Apache-2.0
// The line framing of serial ports (satellite/mcu/src/skr_line.h): COBS, the version byte and the
// CRC, on clean and noisy lines.
#include "skr_line.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace {

using Bytes = std::vector<uint8_t>;

Bytes encode(const Bytes& frame) {
  Bytes out(frame.size() + SKR_LINE_OVERHEAD(frame.size()));
  const size_t n = skr_line_encode(frame.data(), frame.size(), out.data(), out.size());
  EXPECT_GT(n, 0u);
  out.resize(n);
  return out;
}

// A receiver with room for frames of `max` bytes; what it gives back, frame by frame.
struct Receiver {
  explicit Receiver(size_t max) : buf(max + SKR_LINE_RX_EXTRA) {
    skr_line_rx_init(&rx, buf.data(), buf.size());
  }
  std::vector<Bytes> feed(const Bytes& line) {
    std::vector<Bytes> frames;
    for (const uint8_t b : line) {
      if (const size_t n = skr_line_rx_byte(&rx, b); n > 0) {
        frames.emplace_back(skr_line_rx_frame(&rx), skr_line_rx_frame(&rx) + n);
      }
    }
    return frames;
  }
  Bytes buf;
  skr_line_rx rx{};
};

TEST(Line, CrcIsCcittFalse) {
  const std::string check = "123456789";
  EXPECT_EQ(skr_line_crc16(0xFFFF, reinterpret_cast<const uint8_t*>(check.data()), check.size()),
            0x29B1);
}

TEST(Line, FramesOfEveryShapeComeBackWhole) {
  std::mt19937 rng(7);
  Receiver r(1024);
  for (size_t size : {1u, 2u, 253u, 254u, 255u, 256u, 507u, 508u, 509u, 1000u, 1024u}) {
    for (int fill = 0; fill < 3; ++fill) {
      Bytes frame(size);
      for (auto& b : frame) b = fill == 0 ? 0 : fill == 1 ? 0xFF : uint8_t(rng());
      const Bytes line = encode(frame);
      EXPECT_EQ(std::count(line.begin(), line.end(), 0), 1) << size;  // the delimiter only
      EXPECT_EQ(line.back(), 0);
      EXPECT_LE(line.size(), size + SKR_LINE_OVERHEAD(size));
      const auto got = r.feed(line);
      ASSERT_EQ(got.size(), 1u) << size << " fill " << fill;
      EXPECT_EQ(got[0], frame);
    }
  }
  EXPECT_EQ(r.rx.stats.frames, 33u);
  EXPECT_EQ(r.rx.stats.bad_check + r.rx.stats.bad_framing + r.rx.stats.too_long, 0u);
}

TEST(Line, AnEncoderWithoutRoomWritesNothing) {
  const Bytes frame(300, 7);
  Bytes out(frame.size() + SKR_LINE_OVERHEAD(frame.size()) - 1);
  EXPECT_EQ(skr_line_encode(frame.data(), frame.size(), out.data(), out.size()), 0u);
}

TEST(Line, AFlippedByteIsDroppedAndTheNextFrameArrives) {
  Receiver r(64);
  const Bytes a{1, 2, 3, 4, 5}, b{9, 8, 7};
  Bytes line = encode(a);
  line[2] ^= 0x10;
  const Bytes next = encode(b);
  line.insert(line.end(), next.begin(), next.end());
  const auto got = r.feed(line);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], b);
  EXPECT_EQ(r.rx.stats.bad_check + r.rx.stats.bad_framing, 1u);
}

TEST(Line, AFrameLongerThanTheBufferIsDroppedWithoutWritingPastIt) {
  Receiver r(16);
  r.buf.push_back(0xAB);  // a guard byte just past the receiver's room
  skr_line_rx_init(&r.rx, r.buf.data(), r.buf.size() - 1);
  const auto got = r.feed(encode(Bytes(100, 5)));
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(r.rx.stats.too_long, 1u);
  EXPECT_EQ(r.buf.back(), 0xAB);
  ASSERT_EQ(r.feed(encode(Bytes(16, 6))).size(), 1u);  // the next one fits
}

TEST(Line, AnotherVersionAnEmptyFrameAndACutBlockAreCountedApart) {
  Receiver r(64);
  Bytes v2 = encode(Bytes{1, 2});
  // Re-encode by hand with version 2 and a correct CRC: the version check, not the CRC, drops it.
  const uint8_t raw[] = {2, 1, 2};
  const uint16_t crc = skr_line_crc16(0xFFFF, raw, 3);
  const Bytes decoded{2, 1, 2, uint8_t(crc & 0xFF), uint8_t(crc >> 8)};
  Bytes cobs{uint8_t(decoded.size() + 1)};
  cobs.insert(cobs.end(), decoded.begin(), decoded.end());
  ASSERT_EQ(std::count(cobs.begin(), cobs.end(), 0), 0);  // this CRC has no zero byte
  cobs.push_back(0);
  EXPECT_TRUE(r.feed(cobs).empty());
  EXPECT_EQ(r.rx.stats.bad_version, 1u);
  EXPECT_TRUE(r.feed(Bytes{0, 0, 0}).empty());  // an idle line: nothing counted
  EXPECT_TRUE(r.feed(Bytes{5, 1, 0}).empty());  // a block of 4 cut after 1
  EXPECT_EQ(r.rx.stats.bad_framing, 1u);
  EXPECT_EQ(r.feed(v2).size(), 1u);
}

// A seeded noisy line: bytes dropped, flipped and inserted at a set rate. Every frame that comes
// out is one that went in (the CRC lets 1 in 65536 bad frames through: none with this seed), and
// the receiver keeps going.
TEST(Line, ANoisyLineLosesFramesButNeverDeliversAWrongOne) {
  std::mt19937 rng(42);
  Receiver r(200);
  std::vector<Bytes> sent;
  Bytes line;
  for (int i = 0; i < 2000; ++i) {
    Bytes frame(1 + rng() % 200);
    for (auto& b : frame) b = uint8_t(rng());
    frame[0] = uint8_t(i);
    frame[frame.size() > 1 ? 1 : 0] = uint8_t(i >> 8);
    sent.push_back(frame);
    const Bytes enc = encode(frame);
    for (const uint8_t b : enc) {
      const unsigned roll = rng() % 1000;
      if (roll == 0) continue;                        // dropped
      if (roll == 1) line.push_back(uint8_t(rng()));  // inserted
      line.push_back(roll == 2 ? uint8_t(b ^ (1u << (rng() % 8))) : b);
    }
  }
  const auto got = r.feed(line);
  size_t next = 0;
  for (const auto& f : got) {
    while (next < sent.size() && sent[next] != f) ++next;
    ASSERT_LT(next, sent.size()) << "a frame that was never sent";
  }
  const auto& s = r.rx.stats;
  EXPECT_GT(got.size(), 1000u);
  EXPECT_GT(s.bad_check + s.bad_framing, 100u);
  EXPECT_EQ(s.frames, got.size());
}

// A board encodes in one buffer (skr_flow.c): a frame placed SKR_LINE_INPLACE_LEAD(n) bytes in
// comes out as from a separate buffer, for every run of zeros and non-zeros and both block edges.
TEST(Line, EncodesInPlaceFromTheLead) {
  std::mt19937 rng(11);
  for (size_t size : {1u, 2u, 250u, 251u, 252u, 253u, 254u, 255u, 507u, 508u, 509u, 700u}) {
    for (int fill = 0; fill < 4; ++fill) {
      Bytes frame(size);
      for (auto& b : frame)
        b = fill == 0 ? 0 : fill == 1 ? 0xFF : fill == 2 ? uint8_t(rng() % 3) : uint8_t(rng());
      const Bytes want = encode(frame);
      Bytes buf(size + SKR_LINE_OVERHEAD(size));
      std::copy(frame.begin(), frame.end(), buf.begin() + SKR_LINE_INPLACE_LEAD(size));
      const size_t n =
          skr_line_encode(buf.data() + SKR_LINE_INPLACE_LEAD(size), size, buf.data(), buf.size());
      ASSERT_EQ(Bytes(buf.begin(), buf.begin() + n), want) << size << " fill " << fill;
    }
  }
}

}  // namespace
