// SPDX-License-Identifier: Apache-2.0
// A C++ subscriber that takes physical-mode paths (docs/physical-mode.md), for the tests of other
// languages' owners (satellite/python/tests/test_paths_owner.py drives it against a PySketch
// owner). It subscribes to CHANNEL with usePaths(KINDS) and checks each message's content as
// paths_publisher writes it (bytes 0-7 the number, u64 little-endian; byte i >= 8
// (number + i) & 0xFF).
//
//   paths_subscriber ADDRESS CHANNEL KINDS      KINDS: shm, direct or both
//
// Commands on stdin, one a line (answers on stdout, one a line, flushed):
//   stats   -> "stats path_messages=<n> fallbacks=<n> torn=<n> got=<n> first=<n> last=<n>
//               ordered=<0|1> gaps=<n> bad=<n>"  (ordered: every number above the one before;
//               gaps: numbers missing between first and last)
//   clear   forgets what came                                     -> "cleared"
//   quit    exits 0
// It prints "subscribed" when subscribed.
#include "stdin_lines.h"

#include <skrobot/satellite.h>

#include <fcntl.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

namespace {

void say(const std::string& line) {
  std::printf("%s\n", line.c_str());
  std::fflush(stdout);
}

class Subscriber : public skr::sat::Sketch {
 public:
  Subscriber(skr::sat::SketchOptions options, std::string channel, uint8_t kinds)
      : Sketch(std::move(options)), channel_(std::move(channel)), kinds_(kinds) {}

 protected:
  void setup() override {
    satellite().usePaths(channel_, kinds_);
    satellite().subscribe(channel_);
    ::fcntl(0, F_SETFL, ::fcntl(0, F_GETFL) | O_NONBLOCK);
  }
  void loop() override { readCommands(); }
  void onSubscribed(const skr::sat::ChannelInfo&) override { say("subscribed"); }
  void onData(uint16_t, const std::string& payload) override {
    if (payload.size() < 8) {
      ++bad_;
      return;
    }
    uint64_t n = 0;
    std::memcpy(&n, payload.data(), 8);
    for (size_t i = 8; i < payload.size(); ++i) {
      if (static_cast<uint8_t>(payload[i]) != static_cast<uint8_t>((n + i) & 0xFF)) {
        ++bad_;
        return;
      }
    }
    if (got_ == 0) first_ = n;
    if (got_ != 0 && n <= last_) ordered_ = false;
    if (got_ != 0 && n > last_ + 1) gaps_ += n - last_ - 1;
    last_ = n;
    ++got_;
  }

 private:
  void command(const std::string& line) {
    if (line == "stats") {
      const auto s = satellite().pathStats();
      say("stats path_messages=" + std::to_string(s.path_messages) +
          " fallbacks=" + std::to_string(s.fallbacks) + " torn=" + std::to_string(s.torn) +
          " got=" + std::to_string(got_) + " first=" + std::to_string(first_) +
          " last=" + std::to_string(last_) + " ordered=" + (ordered_ ? "1" : "0") +
          " gaps=" + std::to_string(gaps_) + " bad=" + std::to_string(bad_));
    } else if (line == "clear") {
      got_ = first_ = last_ = gaps_ = bad_ = 0;
      ordered_ = true;
      say("cleared");
    } else if (line == "quit") {
      stop();
    }
  }
  void readCommands() {
    if (!skr::test::readStdinLines(pending_, [this](const std::string& line) { command(line); })) {
      stop();  // the test went away
    }
  }

  std::string channel_;
  uint8_t kinds_;
  uint64_t got_ = 0, first_ = 0, last_ = 0, gaps_ = 0, bad_ = 0;
  bool ordered_ = true;
  std::string pending_;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s ADDRESS CHANNEL shm|direct|both\n", argv[0]);
    return 2;
  }
  ::setenv("ROBOT_ADDRESS", argv[1], 1);
  const std::string kinds = argv[3];
  const uint8_t paths = (kinds == "shm" || kinds == "both" ? skr::sat::kPathShm : 0) |
                        (kinds == "direct" || kinds == "both" ? skr::sat::kPathDirect : 0);
  auto options = skr::sat::SketchOptions::fromEnvironment("paths_subscriber");
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  options->rate_hz = 200;
  Subscriber subscriber(std::move(options).value(), argv[2], paths);
  return subscriber.run();
}
