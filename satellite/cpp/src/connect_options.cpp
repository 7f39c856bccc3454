// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/udp.h>
#include <skrobot/satellite/address.h>

#include <cerrno>
#include <cstdlib>

namespace skr::sat {

Result<ConnectOptions> ConnectOptions::fromEnvironment(std::string client_name) {
  ConnectOptions o;
  o.client_name = std::move(client_name);
  if (o.client_name.empty()) o.client_name = program_invocation_short_name;  // GNU: argv[0]
  const auto env = [](const char* name) -> std::string {
    const char* v = std::getenv(name);
    return v != nullptr ? std::string(v) : std::string();
  };
  if (const std::string addr = env("ROBOT_ADDRESS"); !addr.empty()) {
    auto a = Address::parse(addr);
    if (!a) return makeError(a.error().code, "ROBOT_ADDRESS: " + a.error().message);
    o.address = std::move(a).value();
  }
  if (std::string u = env("ROBOT_USER"); !u.empty()) o.user = std::move(u);
  if (std::string p = env("ROBOT_PASSWORD"); !p.empty()) o.password = std::move(p);
  o.tls.ca_file = env("ROBOT_TLS_CA");
  o.tls.cert_file = env("ROBOT_TLS_CERT");
  o.tls.key_file = env("ROBOT_TLS_KEY");
  if (const std::string hex = env("ROBOT_UDP_KEY"); !hex.empty()) {
    auto key = flow::transport::parseUdpKey(hex);
    if (!key) return makeError(key.error().code, "ROBOT_UDP_KEY: " + key.error().message);
    o.udp_key = *key;
  } else if (const std::string file = env("ROBOT_UDP_KEY_FILE"); !file.empty()) {
    auto key = flow::transport::readUdpKeyFile(file);
    if (!key) return makeError(key.error().code, "ROBOT_UDP_KEY_FILE: " + key.error().message);
    o.udp_key = *key;
  }
  return o;
}

}  // namespace skr::sat
