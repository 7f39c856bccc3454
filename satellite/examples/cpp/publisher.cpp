// SPDX-License-Identifier: Apache-2.0
// Publisher, in the sketch style: setup() once, loop() at a steady rate. It publishes a counter on
// "<user>.counter", and only while somebody subscribes (the hub tells it: start/stop publish).
//
//   ROBOT_ADDRESS=local:/tmp/Robot ./publisher [RATE_HZ]
#include <skrobot/satellite.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

using skr::flow::Variant;

class Counter : public skr::sat::Sketch {
 public:
  using Sketch::Sketch;

 protected:
  void setup() override {
    auto added = satellite().addChannel(
        {.name = "counter", .mime = "text/plain", .props = Variant::Map{{"unit", "ticks"}}});
    if (!added) std::fprintf(stderr, "%s\n", added.error().message.c_str());
  }
  void loop() override {
    if (!satellite().hasSubscribers("counter")) return;  // nobody listens: produce nothing
    (void)satellite().publish("counter", std::to_string(next_++));
  }
  void onChannelReady(const skr::sat::ChannelInfo& info) override {
    std::printf("channel %s ready (id %u)\n", info.name.c_str(), info.id);
    std::fflush(stdout);
  }
  void onStartPublish(uint16_t) override {
    std::printf("first subscriber: publishing\n");
    std::fflush(stdout);
  }
  void onStopPublish(uint16_t) override {
    std::printf("no subscriber left: paused at %d\n", next_);
    std::fflush(stdout);
  }

 private:
  int next_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  auto options = skr::sat::SketchOptions::fromEnvironment("publisher");
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  options->rate_hz = argc > 1 ? std::atof(argv[1]) : 20;
  Counter counter(std::move(options).value());
  return counter.run();  // until SIGINT or SIGTERM
}
