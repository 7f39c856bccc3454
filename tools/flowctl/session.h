// SPDX-License-Identifier: Apache-2.0
// flowctl echo and pub: a satellite flow on a loop of flowctl's own (internal).
#pragma once

#include <skrobot/runtime/loop_handles.h>

#include <functional>
#include <string>

#include "cli.h"

namespace flowctl {

namespace sat = skr::sat;

// What echo and pub share: a flow that does not reconnect, and how it ends.
struct Session {
  explicit Session(const Cli& cli, skr::Nanos tick_ns,
                   skr::TimingMode mode = skr::TimingMode::coarse)
      : loop(skr::LoopOptions{.name = "flowctl", .mode = mode, .fast_interval_ns = tick_ns}),
        satellite(loop,
                  [&] {
                    sat::SatelliteOptions o;
                    o.connection = cli.connect;
                    o.reconnect = false;
                    return o;
                  }()),
        signals(skr::stopOnSignals(loop)) {
    satellite.disconnected.connect(&satellite, [this](const std::string& why) {
      if (!finished)
        end(kNoHub,
            "lost the hub at " + satellite.options().connection.address.toString() + ": " + why);
    });
    satellite.error.connect(&satellite, [this](const sat::FlowError& e) {
      const auto code = static_cast<skr::flow::ErrorCode>(e.error);
      if (e.command == 0 || e.command == uint8_t(skr::flow::Code::login) ||
          e.command == uint8_t(skr::flow::Code::chan_add)) {
        int exit_code = exitFor({sat::toErrc(code), ""});
        if (code == skr::flow::ErrorCode::auth_failed) exit_code = kLoginRefused;
        if (code == skr::flow::ErrorCode::io_error) exit_code = kNoHub;
        end(exit_code, explain ? explain(e) : e.message);
      }
    });
    loop.addTickHandler(skr::Tick::one_sec, [this] {
      if (!satellite.isConnected() && ++seconds_unconnected >= 10) {
        end(kNoHub,
            "no answer from the hub at " + satellite.options().connection.address.toString());
      }
    });
  }
  void end(int exit_code, const std::string& why) {
    if (code == kOk && exit_code != kOk) fail(exit_code, why);
    if (code == kOk) code = exit_code;
    loop.stop();
  }
  int run() {
    satellite.start();
    loop.run();
    finished = true;
    satellite.stop();
    return code;
  }

  // What a command adds to a refusal that ends it (a hint for the user); the hub's message if
  // unset.
  std::function<std::string(const sat::FlowError&)> explain;
  skr::Loop loop;
  sat::Satellite satellite;
  skr::StopOnSignals signals;  // SIGINT/SIGTERM stop the loop: flowctl then exits 0
  int code = kOk;
  int seconds_unconnected = 0;
  bool finished = false;  // the loop ended: the flow closes on purpose
};

}  // namespace flowctl
