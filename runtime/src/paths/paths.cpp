// SPDX-License-Identifier: Apache-2.0
// Physical mode (see paths.h): what both sides share.
#include "paths_impl.h"

#include <skrobot/runtime/flow/fd_passing.h>

namespace skr::flow::phys {

namespace msg = flow::msg;
using namespace paths_io;

Paths::Paths(Host host) : host_(std::move(host)) {}

Paths::~Paths() {
  reset();  // closes every peer and path
  spin_ = Spinner();
  listen_watch_ = FdWatch();
  closeFd(listen_fd_);
  if (!listen_path_.empty()) ::unlink(listen_path_.c_str());
  tcp_watch_ = FdWatch();
  closeFd(tcp_fd_);
}

// --- both ---------------------------------------------------------------------------------------

void Paths::closeAll(const std::string& why) {
  std::vector<int> fds;
  for (auto& [fd, p] : peers_) fds.push_back(fd);
  for (int fd : fds) closePeer(fd, why);
  std::vector<uint16_t> chans;
  for (auto& [id, p] : paths_) {
    if (p->fd >= 0) chans.push_back(id);
  }
  for (uint16_t id : chans) failPath(id, why);
}

void Paths::tick() {
  const Nanos now = monotonicNs();
  for (auto& [id, s] : served_) {
    if (s->unrelayed_messages == 0) continue;
    host_.count(msg::PhysCount{id, s->unrelayed_messages, s->unrelayed_bytes});
    s->unrelayed_messages = s->unrelayed_bytes = 0;
  }
  std::erase_if(grants_, [&](const auto& g) { return g.second.expires < now; });
  std::vector<int> late_hellos;
  for (auto& [fd, peer] : peers_) {
    if (!peer->pending_hello.empty() && peer->pending_until <= now) late_hellos.push_back(fd);
  }
  for (int fd : late_hellos) {
    if (auto it = peers_.find(fd); it != peers_.end()) {
      refusePeer(*it->second, "no such grant (a token is good once, for 10 s)");
    }
  }
  std::vector<uint16_t> late;
  for (auto& [id, p] : paths_) {
    report(*p);
    if (p->reader) p->reader->heartbeat();
    if (p->connecting_until != 0 && p->connecting_until <= now) late.push_back(id);
    if (!p->open && p->tag == 0 && p->retry_at != 0 && p->retry_at <= now) request(*p);
  }
  for (uint16_t id : late) failPath(id, "the owner's TCP endpoint does not answer");
}

void Paths::reset() {
  std::vector<int> fds;
  for (auto& [fd, p] : peers_) fds.push_back(fd);
  for (int fd : fds) closePeer(fd, "the owner lost the hub");
  grants_.clear();
  for (auto& [id, p] : paths_) closePath(*p);
  paths_.clear();
  updateSpin();
  // Ids change with the next flow: our channels are offered again when created; rings wait.
  for (auto& [id, sv] : served_) {
    if (sv->ring) idle_rings_.emplace(sv->name, std::move(*sv->ring));
  }
  served_.clear();
}

Paths::Stats Paths::stats() const {
  return stats_;
}

}  // namespace skr::flow::phys
