// SPDX-License-Identifier: Apache-2.0
// A satellite for the soak test (tests/soak/soak.py): one role, reporting on stdout what the
// driver checks, one line per event. It reconnects by itself, as every satellite does.
//
//   ROBOT_ADDRESS=local:/tmp/<app> soak_satellite ROLE NAME [TARGET]
//
//   pub  NAME         publishes 64 bytes on "guest.NAME" every 50 ms while subscribed
//   sub  NAME TARGET  subscribes to TARGET (a full name); prints "DATA" per payload
//   svc  NAME         answers requests on the service "guest.NAME" with their value
//   call NAME TARGET  requests TARGET every 50 ms; prints "RESP" per answer
//   db   NAME SLOT:BASE  VAR_SET of "SLOT-<n % 50>" = BASE + n in the database "soak" every 50 ms
//                     over the synchronous connection; prints "ACK <key> <value>" once answered
//                     (a slot's keys are reused by its next writer, with a higher BASE: the
//                     database stays the same size however long the soak runs)
#include <skrobot/runtime/clock.h>
#include <skrobot/satellite.h>

#include <cstdio>
#include <cstdlib>
#include <string>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: soak_satellite pub|sub|svc|call|db NAME [TARGET]\n");
    return 2;
  }
  const std::string role = argv[1];
  const std::string name = argv[2];
  const std::string target = argc > 3 ? argv[3] : "";
  // db: TARGET is SLOT:BASE.
  const std::string slot = target.substr(0, target.find(':'));
  const int64_t base =
      target.find(':') == std::string::npos ? 0 : std::atoll(target.c_str() + target.find(':') + 1);
  auto options = skr::sat::SatelliteOptions::fromEnvironment("soak-" + role + "-" + name);
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  skr::Loop loop;
  skr::sat::Satellite sat(loop, std::move(options).value());
  const auto say = [](const std::string& line) {
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  };
  if (role == "pub") {
    (void)sat.addChannel({.name = name, .mime = "application/octet-stream"});
  } else if (role == "svc") {
    (void)sat.addChannel({.name = name, .kind = skr::flow::ChannelKind::service});
    sat.serviceRequest.connect(
        &sat, [&sat](const skr::sat::Request& r) { (void)sat.respond(r, r.value); });
  } else if (role == "sub") {
    sat.data.connect(&sat, [&say](uint16_t, const std::string&) { say("DATA"); });
    sat.subscribe(target);
  } else if (role == "call") {
    sat.serviceResponse.connect(&sat, [&say](const skr::sat::Response& r) {
      if (r.ok()) say("RESP");
    });
  } else if (role != "db") {
    std::fprintf(stderr, "unknown role %s\n", role.c_str());
    return 2;
  }
  uint64_t n = 0;
  // The synchronous connection that selected "soak" (0: none yet). A restarted hub numbers its
  // connections from the start again, so a reconnection forgets it: a new synchronous connection
  // with the old number would otherwise write to the user's database.
  uint32_t selected_on = 0;
  sat.connected.connect(&sat, [&say, &selected_on] {
    selected_on = 0;
    say("CONNECTED");
  });
  const std::string payload(64, 'p');
  skr::Nanos last = 0;
  loop.addTickHandler(skr::Tick::fast, [&] {
    const skr::Nanos now = skr::monotonicNs();
    if (now - last < 50 * skr::kNsPerMs) return;
    last = now;
    if (role == "pub") {
      if (sat.hasSubscribers(name)) (void)sat.publish(name, payload);
    } else if (role == "call") {
      if (sat.isConnected()) (void)sat.request(target, "echo", skr::flow::Variant(int64_t(n++)));
    } else if (role == "db" && sat.isConnected()) {
      auto sync = sat.syncClient();  // blocking, as a satellite that writes synchronously is
      if (!sync) return;
      // A new synchronous connection (after a restart) starts on the user's database.
      if ((*sync)->login().connection_id != selected_on) {
        if (!(*sync)->selectDatabase("soak")) return;
        selected_on = (*sync)->login().connection_id;
      }
      const std::string key = slot + "-" + std::to_string(n % 50);
      const int64_t value = base + static_cast<int64_t>(n);
      if ((*sync)->set(key, skr::flow::Variant(value))) {
        say("ACK " + key + " " + std::to_string(value));
        ++n;
      }
    }
  });
  sat.start();
  loop.run();
  return 0;
}
