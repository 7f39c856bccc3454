// Where the hub is and who we are: ROBOT_ADDRESS, ROBOT_USER, ROBOT_PASSWORD.
//
//   ROBOT_ADDRESS=local:/tmp/Robot        a Unix socket (the default)
//   ROBOT_ADDRESS=tcp:robot.local:9000    TCP; the port defaults to 9000; IPv6 as tcp:[::1]:9000
#pragma once

#include <skrobot/core/result.h>
#include <skrobot/flow/protocol.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::sat {

constexpr uint16_t kDefaultTcpPort = 9000;
constexpr std::string_view kDefaultAddress = "local:/tmp/Robot";

struct Address {
  enum class Kind { local, tcp };
  Kind kind = Kind::local;
  std::string path = "/tmp/Robot";  // Kind::local
  std::string host;                 // Kind::tcp: a name or a numeric address
  uint16_t port = kDefaultTcpPort;  // Kind::tcp

  // "local:/tmp/Robot" or "tcp:host:9000", the form parse() reads.
  [[nodiscard]] std::string toString() const;
  // Parses "local:/path" or "tcp:host[:port]". Errc::invalid_argument, naming what is wrong.
  [[nodiscard]] static Result<Address> parse(std::string_view text);
};

// How to reach and log in to a hub. Plain data; copy it freely.
struct ConnectOptions {
  Address address;
  std::string user = "guest";
  std::string password = "password";
  std::string client_name;  // shown in the hub's log lines; may be empty
  uint32_t max_frame_bytes = flow::kDefaultMaxFrameBytes;  // a bigger incoming frame is an error
  uint32_t timeout_ms = 5000;  // connect and each synchronous reply (SERVICE_CALL adds its own)

  // Reads ROBOT_ADDRESS, ROBOT_USER and ROBOT_PASSWORD; unset (or empty) variables keep the
  // defaults above. Errc::invalid_argument when ROBOT_ADDRESS cannot be parsed.
  [[nodiscard]] static Result<ConnectOptions> fromEnvironment(std::string client_name = {});
};

}  // namespace skr::sat
