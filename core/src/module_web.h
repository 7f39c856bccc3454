// SPDX-License-Identifier: Apache-2.0
// A module's WebSocket endpoints on the hub's web port (plugin ABI 1.8: ws_serve, ws_unserve,
// ws_send, ws_close). Each endpoint is a path the web port upgrades for this module
// (FlowServer::serveWebSocket); each client is a Peer over an http::MessageTransport, with an
// output queue bounded by the endpoint's max_queued_bytes (droppable messages go first). The
// module hears opened, message and closed on the main loop, where modules with channel calls run.
// Destroying it unserves every path and drops every connection (close 1001) with no more events:
// the module's code may go after that.
#pragma once

#include <skrobot/hub/flow/server.h>
#include <skrobot/plugin.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

namespace skr {

class ModuleWebSockets {
 public:
  // `log_source`: the module's ("mod.<name>").
  ModuleWebSockets(flow::FlowServer& server, std::string log_source);
  ~ModuleWebSockets();
  ModuleWebSockets(const ModuleWebSockets&) = delete;
  ModuleWebSockets& operator=(const ModuleWebSockets&) = delete;
  ModuleWebSockets(ModuleWebSockets&&) = delete;
  ModuleWebSockets& operator=(ModuleWebSockets&&) = delete;

  // The C calls, their statuses as plugin.h says.
  skr_status serve(const char* path, const char* subprotocol, size_t max_message_bytes,
                   size_t max_queued_bytes, const skr_ws_events* events, void* user,
                   skr_sub_handle* handle_out);
  skr_status unserve(skr_sub_handle handle);
  skr_status send(skr_ws_conn conn, bool text, const void* data, size_t size, bool droppable);
  skr_status close(skr_ws_conn conn, uint16_t code, const char* reason);

  class Peer;

 private:
  friend class Peer;
  struct Endpoint {
    std::string path;
    skr_ws_events events{};  // the module's, as far as its struct_size reaches
    void* user = nullptr;
    size_t max_queued_bytes = 0;
  };

  void accepted(skr_sub_handle endpoint, std::unique_ptr<flow::http::MessageTransport> t);
  void peerClosed(skr_ws_conn conn, const std::string& why);  // frees the peer
  // Closes an endpoint's connections (1001); their events stop at once.
  void dropPeers(skr_sub_handle endpoint);

  flow::FlowServer& server_;
  std::string log_source_;
  std::map<skr_sub_handle, Endpoint> endpoints_;
  std::map<skr_ws_conn, std::unique_ptr<Peer>> peers_;
  skr_sub_handle next_handle_ = 1;
};

}  // namespace skr
