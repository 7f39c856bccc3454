// SPDX-License-Identifier: Apache-2.0
// What the hub's supervisor of satellites asks of the server (server.h, "what the hub's
// supervisor of satellites asks"; docs/robot.md): their runs' passwords, their logins, their
// channels, and its ADMIN commands.
#include <skrobot/hub/flow/server.h>

#include "connection.h"
#include "server_impl.h"

namespace skr::flow {

Result<std::string> FlowServer::addSatellitePassword(const std::string& account,
                                                     const std::string& name) {
  if (!impl_->session.auth) return makeError(Errc::closed, "the server has not started");
  return impl_->session.auth->addSatellitePassword(account.empty() ? name : account, name,
                                                   account.empty());
}

void FlowServer::removeSatellitePassword(const std::string& user, const std::string& password) {
  if (impl_->session.auth) impl_->session.auth->removeSatellitePassword(user, password);
}

void FlowServer::onSatelliteLogin(
    std::function<void(const std::string& name, uint32_t connection)> fn) {
  impl_->session.on_satellite_login = std::move(fn);
}

bool FlowServer::hasChannel(const std::string& name) const {
  return impl_->channels.findByName(name) != nullptr;
}

std::vector<FlowServer::SatelliteFlow> FlowServer::flowsOfSatellite(const std::string& name) const {
  std::vector<SatelliteFlow> out;
  for (const auto& [id, c] : impl_->connections) {
    if (c->satellite != name) continue;
    SatelliteFlow f{id, c->user, c->client_name, {}};
    for (uint16_t chan : c->owned) {
      if (const Channel* ch = impl_->channels.find(chan)) f.channels.push_back(ch->name);
    }
    out.push_back(std::move(f));
  }
  return out;
}

void FlowServer::addAdminCommand(const std::string& name, AdminCommand run) {
  impl_->admin.more[name] = std::move(run);
}

void FlowServer::removeAdminCommand(const std::string& name) noexcept {
  impl_->admin.more.erase(name);
}

}  // namespace skr::flow
