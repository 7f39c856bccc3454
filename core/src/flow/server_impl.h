// SPDX-License-Identifier: Apache-2.0
// FlowServer::Impl: the hub's FlowNetwork server. Its parts are the Hub (hub.h: the endpoints and
// one room per family of the protocol); this adds the listeners (transport.h: Unix socket, TCP,
// TLS on TCP; serial_ports.h; udp_port.h), accepting connections, the loop's handles that flush
// output once per iteration and run the sweep. Main loop thread only. docs/internals.md is the map.
#pragma once

#include "hub.h"
#include "serial_ports.h"
#include "udp_port.h"

#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/flow/tls.h>
#include <skrobot/runtime/flow/transport.h>

#include <uv.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace skr::flow {

struct FlowServer::Impl : Hub {
  Impl(Loop& loop, ServerOptions options);

  std::string unix_path;
  uint16_t tcp_port = 0;
  bool started = false;
  // Loaded by start() when opt.tls is set: every TCP connection is then a TLS session on it.
  std::optional<TlsContext> tls;

  std::unique_ptr<transport::Listener> unix_listener;
  std::unique_ptr<transport::Listener> tcp_listener;
  std::unique_ptr<SerialPorts> serial_ports;  // server.serial
  std::unique_ptr<UdpPort> udp_port;          // server.udp
  uv_prepare_t* flush_prepare = nullptr;
  uv_check_t* flush_check = nullptr;
  uv_timer_t* sweep_timer = nullptr;

  Result<void> start();
  void stop() noexcept;
  Result<void> listenUnix();
  Result<void> listenTcp();
  Result<void> listenUdp();
  // A connection, or a serial line's session (`serial`: its port's settings).
  void accept(std::unique_ptr<transport::Transport> transport,
              const transport::SerialOptions* serial = nullptr);
};

}  // namespace skr::flow
