// SPDX-License-Identifier: Apache-2.0
// Service caller: a blocking call (over a short-lived synchronous connection, so the flow never
// blocks), then an asynchronous request whose answer arrives as an event on the flow.
//
//   ROBOT_ADDRESS=local:/tmp/Robot ./service_caller [SERVICE]
#include <skrobot/satellite.h>

#include <cstdio>
#include <string>

using skr::flow::Variant;

int main(int argc, char** argv) {
  const std::string service = argc > 1 ? argv[1] : "guest.adder";
  auto options = skr::sat::SatelliteOptions::fromEnvironment("service_caller");
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  skr::Loop loop;
  skr::sat::Satellite sat(loop, std::move(options).value());
  int status = 1;

  auto callBoth = [&] {
    // Blocking: this thread waits for the answer (up to 2 s).
    auto sum = sat.call(service, "add", Variant::List{1, 2, 3}, 2000);
    if (!sum) {
      std::printf("blocking call failed: %s\n", sum.error().message.c_str());
      loop.stop();
      return;
    }
    std::printf("blocking: 1 + 2 + 3 = %s\n", skr::flow::variantToJsonText(*sum).c_str());
    // Asynchronous: the answer comes later, matched by its tag.
    auto tag = sat.request(service, "add", Variant::List{4, 5}, [&](const skr::sat::Response& r) {
      std::printf("async: 4 + 5 = %s\n", skr::flow::variantToJsonText(r.value).c_str());
      status = r.ok() ? 0 : 1;
      loop.stop();
    });
    if (!tag) loop.stop();
  };
  // Call once the service exists: now (when connected) or when it appears.
  sat.connected.connect(&sat, [&] {
    if (sat.channel(service) != nullptr) callBoth();
  });
  sat.channelAdded.connect(&sat, [&](const skr::sat::ChannelInfo& info) {
    if (info.name == service) callBoth();
  });
  sat.start();
  loop.run();
  std::fflush(stdout);
  return status;
}
