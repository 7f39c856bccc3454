// SPDX-License-Identifier: Apache-2.0
// A channel owner that offers physical-mode paths (docs/physical-mode.md), for the tests of other
// languages' subscribers (satellite/python/tests/test_paths.py). It owns "<user>.<channel>" with
// the paths asked for, and publishes numbered messages whose content a reader can check:
//   bytes 0-7   the message number (u64, little-endian, from 1, never reused by this process)
//   byte i >= 8 (number + i) & 0xFF
//
//   paths_publisher ADDRESS CHANNEL KINDS SLOT_BYTES [RATE_HZ [COUNT]]
//     KINDS: shm, direct, both or none (relayed only); SLOT_BYTES: the ring's largest message.
//     With COUNT: once the channel has a subscriber, publishes COUNT messages at RATE_HZ, then
//     waits (for commands, or SIGTERM).
//
// Commands on stdin, one a line (answers on stdout, one a line, flushed):
//   pub N SIZE     N messages of SIZE bytes (>= 8) at once          -> "published <last number>"
//   zc N SIZE      the same, each filled in a shared-memory slot in place (beginPublish)
//                                                  -> "published <last number>" or "zc-failed"
//   slow N SIZE    N messages, one per loop (RATE_HZ), then         -> "published <last number>"
//   ts N SIZE      N messages, one per loop, whose bytes 8-15 are CLOCK_MONOTONIC in ns when
//                  published (for one-way latency on this machine)  -> "published <last number>"
//   reset          closes every path as broken (resetPaths)         -> "reset"
//   stats          -> "stats served_shm=<n> served_direct=<n>"
//   quit           exits 0
// It prints "ready <id>" when its channel is created and "subscribed" at its first subscriber.
#include "stdin_lines.h"

#include <skrobot/satellite.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>

namespace {

void say(const std::string& line) {
  std::printf("%s\n", line.c_str());
  std::fflush(stdout);
}

void fill(char* out, size_t size, uint64_t number) {
  for (int b = 0; b < 8 && size_t(b) < size; ++b) out[b] = char((number >> (8 * b)) & 0xFF);
  for (size_t i = 8; i < size; ++i) out[i] = char((number + i) & 0xFF);
}

class Publisher : public skr::sat::Sketch {
 public:
  Publisher(skr::sat::SketchOptions options, std::string channel, bool direct, bool shm,
            uint64_t slot_bytes, long count)
      : Sketch(std::move(options)), channel_(std::move(channel)), count_(count) {
    spec_.name = channel_;
    spec_.physical.direct = direct;
    spec_.physical.shm = shm;
    spec_.physical.ring = {4, slot_bytes, 8};
  }

 protected:
  void setup() override {
    auto added = satellite().addChannel(spec_);
    if (!added) say("error " + added.error().message);
    ::fcntl(0, F_SETFL, ::fcntl(0, F_GETFL) | O_NONBLOCK);
  }
  void loop() override {
    readCommands();
    if (slow_left_ > 0) {
      publishOne(slow_size_, stamp_);
      if (--slow_left_ == 0) say("published " + std::to_string(number_));
    }
  }
  void onChannelReady(const skr::sat::ChannelInfo& info) override {
    say("ready " + std::to_string(info.id));
  }
  void onStartPublish(uint16_t) override {
    say("subscribed");
    if (count_ > 0 && !counted_) {
      counted_ = true;
      slow_left_ = count_;
      slow_size_ = 64;
    }
  }

 private:
  void publishOne(size_t size, bool stamp = false) {
    std::string payload(size, '\0');
    fill(payload.data(), payload.size(), ++number_);
    if (stamp && size >= 16) {
      const int64_t t = skr::monotonicNs();
      std::memcpy(payload.data() + 8, &t, sizeof t);
    }
    (void)satellite().publish(channel_, payload);
  }
  void command(const std::string& line) {
    std::istringstream in(line);
    std::string what;
    long n = 0;
    size_t size = 8;
    in >> what >> n >> size;
    size = std::max<size_t>(size, 8);
    if (what == "pub") {
      for (long i = 0; i < n; ++i) publishOne(size);
      say("published " + std::to_string(number_));
    } else if (what == "zc") {
      for (long i = 0; i < n; ++i) {
        auto slot = satellite().beginPublish(channel_);
        if (slot.size() < size) return say("zc-failed");
        fill(reinterpret_cast<char*>(slot.data()), size, ++number_);
        if (!satellite().commitPublish(channel_, size, static_cast<int64_t>(number_))) {
          return say("zc-failed");
        }
      }
      say("published " + std::to_string(number_));
    } else if (what == "slow" || what == "ts") {
      slow_left_ = n;
      slow_size_ = size;
      stamp_ = what == "ts";
    } else if (what == "reset") {
      satellite().resetPaths();
      say("reset");
    } else if (what == "stats") {
      const auto s = satellite().pathStats();
      say("stats served_shm=" + std::to_string(s.served_shm) +
          " served_direct=" + std::to_string(s.served_direct));
    } else if (what == "quit") {
      stop();
    }
  }
  void readCommands() {
    if (!skr::test::readStdinLines(pending_, [this](const std::string& line) { command(line); })) {
      stop();  // the test went away
    }
  }

  std::string channel_;
  skr::sat::ChannelSpec spec_;
  long count_ = 0;
  bool counted_ = false;
  uint64_t number_ = 0;
  long slow_left_ = 0;
  size_t slow_size_ = 64;
  bool stamp_ = false;
  std::string pending_;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr,
                 "usage: %s ADDRESS CHANNEL shm|direct|both|none SLOT_BYTES [RATE_HZ [COUNT]]\n",
                 argv[0]);
    return 2;
  }
  ::setenv("ROBOT_ADDRESS", argv[1], 1);
  const std::string kinds = argv[3];
  const bool direct = kinds == "direct" || kinds == "both";
  const bool shm = kinds == "shm" || kinds == "both";
  auto options = skr::sat::SketchOptions::fromEnvironment("paths_publisher");
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  options->rate_hz = argc > 5 ? std::atof(argv[5]) : 200;
  const long count = argc > 6 ? std::atol(argv[6]) : 0;
  Publisher publisher(std::move(options).value(), argv[2], direct, shm,
                      std::strtoull(argv[4], nullptr, 10), count);
  return publisher.run();
}
