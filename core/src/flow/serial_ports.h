// SPDX-License-Identifier: Apache-2.0
// The serial ports of server.serial: each configured device (a path or a glob) opened as a
// transport::SerialPort when it exists, reopened when it comes back (a USB adapter unplugged and
// plugged again), its sessions handed to the server as connections. A vanished device is logged
// and waited for, never an error. Main loop thread only.
#pragma once

#include <skrobot/runtime/flow/serial.h>
#include <skrobot/runtime/loop_handles.h>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace skr::flow {

class SerialPorts {
 public:
  using Accept =
      std::function<void(std::unique_ptr<transport::Transport>, const transport::SerialOptions&)>;
  // How often a listed device that is not open is looked for.
  static constexpr Nanos kRescan = kNsPerSec;

  SerialPorts(Loop& loop, std::vector<transport::SerialOptions> config, Accept accept);

  // Opens what exists now and starts looking for the rest.
  void start();
  void stop() noexcept;

  struct PortView {
    std::string device;
    bool open = false;
    bool in_session = false;
    transport::SerialStats stats;
  };
  // Every device seen since start, open or not, and each configured device or glob not seen yet
  // (hub.stats).
  [[nodiscard]] std::vector<PortView> view() const;

 private:
  void scan();
  void open(const transport::SerialOptions& entry, const std::string& device);

  Loop& loop_;
  std::vector<transport::SerialOptions> config_;
  Accept accept_;
  Timer rescan_;
  std::map<std::string, std::unique_ptr<transport::SerialPort>> open_;  // by device
  std::map<std::string, transport::SerialStats> closed_;  // a port's last figures while it is away
  std::map<std::string, std::string> failing_;            // device -> last error logged
};

}  // namespace skr::flow
