// SPDX-License-Identifier: Apache-2.0
// Subscriber, in the loop-integrated style: a Satellite on an skr::Loop, its events as signals.
// It subscribes by name (and waits for the channel to appear), then prints every payload.
//
//   ROBOT_ADDRESS=local:/tmp/Robot ./subscriber [CHANNEL [COUNT]]
#include <skrobot/satellite.h>

#include <cstdio>
#include <cstdlib>
#include <string>

int main(int argc, char** argv) {
  const std::string channel = argc > 1 ? argv[1] : "guest.counter";
  const long count = argc > 2 ? std::atol(argv[2]) : 0;  // 0: forever

  auto options = skr::sat::SatelliteOptions::fromEnvironment("subscriber");
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  skr::Loop loop;
  skr::sat::Satellite sat(loop, std::move(options).value());

  sat.subscribed.connect(&sat, [](const skr::sat::ChannelInfo& info) {
    std::printf("subscribed to %s (id %u, props %s)\n", info.name.c_str(), info.id,
                skr::flow::variantToJsonText(info.props).c_str());
    std::fflush(stdout);
  });
  long received = 0;
  sat.data.connect(&sat, [&](uint16_t, const std::string& payload) {
    std::printf("%s\n", payload.c_str());
    std::fflush(stdout);
    if (count > 0 && ++received >= count) loop.stop();
  });
  sat.disconnected.connect(&sat, [](const std::string& why) {
    std::printf("disconnected (%s): reconnecting\n", why.c_str());
    std::fflush(stdout);
  });

  sat.subscribe(channel);
  sat.start();
  loop.run();
  return 0;
}
