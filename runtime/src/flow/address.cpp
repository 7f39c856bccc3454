// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/address.h>

#include <charconv>

namespace skr::flow {

std::string Address::toString() const {
  if (kind == Kind::local) return "local:" + path;
  if (kind == Kind::serial) return "serial:" + path + "@" + std::to_string(baud);
  const bool v6 = host.find(':') != std::string::npos;
  const char* scheme = kind == Kind::tls ? "tls:" : kind == Kind::udp ? "udp:" : "tcp:";
  return std::string(scheme) + (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

Result<Address> Address::parse(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return makeError(
        Errc::invalid_argument,
        "bad hub address \"" + std::string(text) + "\": " + why +
            " (expected local:/path, tcp:host[:port], tls:host[:port], serial:/dev/path[@baud] or "
            "udp:host[:port])");
  };
  Address a;
  if (text.starts_with("local:")) {
    a.path = std::string(text.substr(6));
    if (a.path.empty()) return bad("empty socket path");
    if (a.path.size() >= 108) return bad("socket path longer than 107 bytes");
    return a;
  }
  if (text.starts_with("serial:")) {
    a.kind = Kind::serial;
    std::string_view rest = text.substr(7);
    const size_t at = rest.rfind('@');
    a.path = std::string(rest.substr(0, at));
    if (!a.path.starts_with("/")) return bad("the device must be an absolute path");
    if (at != std::string_view::npos) {
      const std::string_view rate = rest.substr(at + 1);
      const auto [end, ec] = std::from_chars(rate.data(), rate.data() + rate.size(), a.baud);
      if (ec != std::errc() || end != rate.data() + rate.size() || a.baud == 0) {
        return bad("the rate after '@' must be a number of baud");
      }
    }
    return a;
  }
  if (text.starts_with("tcp:")) {
    a.kind = Kind::tcp;
  } else if (text.starts_with("tls:")) {
    a.kind = Kind::tls;
  } else if (text.starts_with("udp:")) {
    a.kind = Kind::udp;
    a.port = kDefaultUdpPort;
  } else {
    return bad("unknown transport");
  }
  std::string_view rest = text.substr(4);
  std::string_view port;
  if (rest.starts_with("[")) {  // [v6]:port
    const size_t close = rest.find(']');
    if (close == std::string_view::npos) return bad("missing ']'");
    a.host = std::string(rest.substr(1, close - 1));
    rest.remove_prefix(close + 1);
    if (!rest.empty()) {
      if (rest[0] != ':') return bad("text after ']'");
      port = rest.substr(1);
    }
  } else {
    const size_t colon = rest.rfind(':');
    a.host = std::string(rest.substr(0, colon));
    if (colon != std::string_view::npos) port = rest.substr(colon + 1);
  }
  if (a.host.empty()) return bad("empty host");
  if (!port.empty() || (rest.size() > 0 && rest.back() == ':')) {
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (ec != std::errc() || end != port.data() + port.size() || value == 0 || value > 65535) {
      return bad("port must be 1-65535");
    }
    a.port = static_cast<uint16_t>(value);
  }
  return a;
}

}  // namespace skr::flow
