// SPDX-License-Identifier: Apache-2.0
// Service provider: owns the service channel "<user>.adder" and answers its requests.
//   add  [numbers...]  -> their sum
//   echo value         -> the value
//
//   ROBOT_ADDRESS=local:/tmp/Robot ./service_provider
#include <skrobot/satellite.h>

#include <cstdio>

namespace {

using skr::flow::Variant;

class Adder : public skr::sat::Sketch {
 public:
  using Sketch::Sketch;

 protected:
  void setup() override {
    (void)satellite().addChannel({.name = "adder",
                                  .kind = skr::flow::ChannelKind::service,
                                  .mime = "application/x-skrobot-variant",
                                  .props = Variant::Map{{"commands", "add, echo"}}});
  }
  void onChannelReady(const skr::sat::ChannelInfo& info) override {
    std::printf("serving %s\n", info.name.c_str());
    std::fflush(stdout);
  }
  void onRequest(const skr::sat::Request& request) override {
    Variant answer = Variant::Map{{"error", "unknown command " + request.command}};
    if (request.command == "echo") answer = request.value;
    if (request.command == "add" && request.value.isList()) {
      double sum = 0;
      for (const auto& v : *request.value.asList()) sum += v.asDouble().value_or(0);
      answer = sum;
    }
    (void)satellite().respond(request, answer);
  }
};

}  // namespace

int main() {
  auto options = skr::sat::SketchOptions::fromEnvironment("service_provider");
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  Adder adder(std::move(options).value());
  return adder.run();
}
