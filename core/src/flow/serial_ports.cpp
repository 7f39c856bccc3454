// SPDX-License-Identifier: Apache-2.0
#include "serial_ports.h"

#include "endpoint.h"

#include <skrobot/runtime/log.h>

#include <fnmatch.h>
#include <glob.h>

#include <algorithm>

namespace skr::flow {
namespace {

// The devices a configured name stands for now: itself, or what its glob matches. Reads /dev, an
// in-memory file system: no disk I/O on the loop thread.
std::vector<std::string> devicesOf(const std::string& pattern) {
  if (pattern.find_first_of("*?[") == std::string::npos) return {pattern};
  std::vector<std::string> out;
  glob_t g{};
  if (::glob(pattern.c_str(), GLOB_NOSORT, nullptr, &g) == 0) {
    for (size_t i = 0; i < g.gl_pathc; ++i) out.emplace_back(g.gl_pathv[i]);
  }
  ::globfree(&g);
  return out;
}

}  // namespace

SerialPorts::SerialPorts(Loop& loop, std::vector<transport::SerialOptions> config, Accept accept)
    : loop_(loop), config_(std::move(config)), accept_(std::move(accept)) {}

void SerialPorts::start() {
  if (config_.empty()) return;
  rescan_ = Timer(loop_, [this] { scan(); });
  rescan_.startEvery(kRescan);
  scan();
}

void SerialPorts::stop() noexcept {
  rescan_.stop();
  open_.clear();
}

void SerialPorts::scan() {
  for (const transport::SerialOptions& entry : config_) {
    for (const std::string& device : devicesOf(entry.device)) {
      if (!open_.contains(device)) open(entry, device);
    }
  }
}

void SerialPorts::open(const transport::SerialOptions& entry, const std::string& device) {
  transport::SerialOptions options = entry;
  options.device = device;
  auto port = transport::SerialPort::open(
      loop_, options,
      [this, options](std::unique_ptr<transport::Transport> t) { accept_(std::move(t), options); },
      [this, device](const std::string& why) {
        log::warn(kLogSource, "SERIAL-LOST", why + "; waiting for it to come back");
        auto it = open_.find(device);
        if (it == open_.end()) return;
        closed_[device] = it->second->stats();
        // Destroyed from the loop, not from inside its own callback.
        loop_.post([gone = std::shared_ptr<transport::SerialPort>(std::move(it->second))] {});
        open_.erase(it);
      });
  if (!port) {
    // Logged once per reason: a port that stays away is looked for quietly.
    if (port.error().code != Errc::not_found && failing_[device] != port.error().message) {
      log::warn(kLogSource, "SERIAL-OPEN-FAILED", port.error().message);
    }
    failing_[device] = port.error().message;
    return;
  }
  failing_.erase(device);
  log::info(kLogSource, "SERIAL-OPEN",
            device + " at " + std::to_string(options.baud) + " baud, paced at " +
                std::to_string(transport::pacedBytesPerSecond(options)) + " B/s" +
                (options.account.empty() ? "" : ", bound to account \"" + options.account + "\""));
  open_[device] = std::move(port).value();
  closed_.erase(device);
}

std::vector<SerialPorts::PortView> SerialPorts::view() const {
  std::vector<PortView> out;
  for (const auto& [device, port] : open_) {
    out.push_back({device, true, port->inSession(), port->stats()});
  }
  for (const auto& [device, stats] : closed_) out.push_back({device, false, false, stats});
  // A configured device (or glob) not seen yet is listed too, away: plugged in nowhere so far.
  for (const transport::SerialOptions& entry : config_) {
    const bool seen = std::any_of(out.begin(), out.end(), [&](const PortView& v) {
      return ::fnmatch(entry.device.c_str(), v.device.c_str(), FNM_PATHNAME) == 0;
    });
    if (!seen) out.push_back({entry.device, false, false, {}});
  }
  return out;
}

}  // namespace skr::flow
