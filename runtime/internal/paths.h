// SPDX-License-Identifier: Apache-2.0
// Physical mode (docs/physical-mode.md): the owner's side (a listener for the subscribers the hub
// granted a path, a shared-memory ring per channel, direct sockets) and the subscriber's side (a
// path per channel it asked one for, with fallback to the relay). The runtime's, internal (never
// installed): used by the satellite library (Satellite::Impl, as owner and subscriber) and by the
// hub's module host (ModuleFlow, as a module's owner side), each through its Host. Runs on the
// thread of Host::loop. The sources are runtime/src/paths/.
// The path socket speaks the reduced framing of skrobot/runtime/flow/path_framing.h.
#pragma once

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/flow/shm_ring.h>
#include <skrobot/runtime/loop_handles.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace skr::flow::phys {

inline constexpr Nanos kGrantLifetimeNs = 10 * kNsPerSec;
// How long a HELLO waits for its grant, which the hub sent us when it sent the subscriber its path.
inline constexpr Nanos kHelloWaitNs = 2 * kNsPerSec;
// What an owner keeps of what it sent on direct paths, for a subscriber that falls back to the
// relay (EV_PHYS_RESUME): the last messages of up to 64 KiB each, 1 MiB of them in all, while a
// direct path is served and for 10 s after the last one closed.
inline constexpr size_t kKeptMessageBytes = 64 << 10;
inline constexpr size_t kKeptBytes = 1 << 20;
inline constexpr size_t kSpareBuffers = 16;
// How long a woken shared-memory reader polls its ring after a message that came this soon after
// the one before (or after skipping some), before it waits for its eventfd again: a dense stream
// is then read without wake-ups (and the owner writes no eventfd); sparse messages cost no
// polling.
inline constexpr Nanos kLingerNs = 20'000;

class Paths {
 public:
  // What its user (a satellite, or the hub for a module) gives its paths: sending on the flow,
  // emitting data, naming channels.
  struct Host {
    Loop* loop = nullptr;  // the satellite's (or module's) loop: Paths runs on its thread
    std::function<void(const flow::msg::PhysOffer&)> offer;
    std::function<void(const flow::msg::PhysRequest&)> request;
    std::function<void(const flow::msg::PhysState&)> state;
    std::function<void(const flow::msg::PhysCount&)> count;
    std::function<void(const flow::msg::PhysReceived&)> received;
    std::function<void(const flow::msg::PhysSwitched&)> switched;
    std::function<void(const flow::msg::PhysFallback&)> fallback;
    std::function<void(const flow::msg::PhysReplay&)> replay;
    std::function<uint32_t()> next_tag;
    // Data from a path: the view (for shared memory, the slot in place), then, when someone
    // wants one, the copy (for shared memory only if the read was not torn).
    std::function<void(uint16_t chan_id, std::string_view payload)> deliver_view;
    std::function<bool()> wants_copy;
    std::function<void(uint16_t chan_id, std::string payload)> deliver_copy;
    std::function<uint16_t()> hub_minor;  // the flow's protocol minor
    // "<IPv4>:<port>" to serve direct paths to other machines on too (port 0: any); "": none.
    std::string tcp_listen;
  };
  explicit Paths(Host host);
  ~Paths();
  Paths(const Paths&) = delete;
  Paths& operator=(const Paths&) = delete;

  // --- the owner's side ---
  // One of our channels was created (again): offer its paths. `kinds`: msg::kPhysDirect and/or
  // msg::kPhysShm (0: none); `ring`: the shared-memory ring's geometry.
  void serve(uint16_t chan_id, const std::string& name, uint8_t kinds,
             const shm::RingGeometry& ring);
  void onGrant(const flow::msg::EvPhysGrant& m);
  void onRevoke(const flow::msg::EvPhysRevoke& m);
  // Ours: whether the relay is still needed; a channel we follow: the marker of a 1.8 hub, or of
  // an owner that does not answer EV_PHYS_SWITCH.
  void onRelay(const flow::msg::EvPhysRelay& m);
  // A subscriber's path works (1.9): tell the hub our last message number, before publishing on.
  void onSwitch(const flow::msg::EvPhysSwitch& m);
  // A subscriber's direct path broke (1.11): replay what we kept after its last message, then
  // the end, and publish to the hub again, before publishing anything else.
  void onResume(const flow::msg::EvPhysResume& m);
  [[nodiscard]] bool serves(uint16_t chan_id) const { return served_.count(chan_id) != 0; }
  [[nodiscard]] bool hasRing(uint16_t chan_id) const;
  // One of our channels is gone (not the flow): its peers are closed, its grants dropped; its
  // ring waits for a channel of the same name, as after reset().
  void unserve(uint16_t chan_id);
  // Delivers on our paths; true when it must also go through the hub (someone is relayed).
  bool publish(uint16_t chan_id, std::string_view payload, int64_t capture_ns);
  // The shared-memory slot to fill in place (empty: no ring, or every slot leased), then its
  // commit, which delivers to the other paths (and says whether the hub needs it) as publish().
  std::span<std::byte> beginPublish(uint16_t chan_id);
  std::optional<std::string_view> commitPublish(uint16_t chan_id, size_t size, int64_t capture_ns,
                                                bool& relay);

  // --- the subscriber's side ---
  // Paths to ask for `name` whenever we are subscribed to it (0: none); `spin`: a shared-memory
  // one is polled on each turn of the loop instead of waiting for its eventfd.
  void want(const std::string& name, uint8_t paths, bool spin = false);
  void onSubscribed(const std::string& name, uint16_t chan_id);
  void onUnsubscribed(uint16_t chan_id);
  void onPath(const flow::msg::EvPhysPath& m);
  // The hub relays a channel we follow no more after message `seq` of its owner (1.9).
  void onMarker(const flow::msg::EvPhysMarker& m);
  // EV_ERROR for a PHYS_REQUEST: true when it was ours (then it is logged here, not an error).
  bool onRefused(const flow::msg::EvError& e);

  // Closes every peer and path as broken (subscribers fall back and ask again).
  void closeAll(const std::string& why);
  // Each second: counts (ours and what came on our paths), expired grants, leases kept alive, paths
  // asked again.
  void tick();
  // The flow closed: paths and grants are void (rings and the listener stay for the next one).
  void reset();

  struct Stats {
    uint64_t served_direct = 0, served_shm = 0;  // peers now
    uint64_t path_messages = 0;                  // received on paths
    uint64_t dropped_before_marker = 0, torn = 0, fallbacks = 0;
    uint64_t missed = 0;  // shared memory: published while we were busy, never read (newest wins)
    uint64_t polled = 0;  // shared memory, woken: read while lingering (kLingerNs), no wake-up
  };
  [[nodiscard]] Stats stats() const;

  struct Peer;
  struct Path;
  struct Served;

 private:
  void ensureListener();
  void ensureTcpListener();
  bool sendDirect(Served& sv, std::string_view payload, int64_t capture_ns);
  // Keeps what was sent on direct paths for a fallback (kKeptBytes).
  void keep(Served& sv, std::string_view payload);
  void onAccept(int listen_fd, bool tcp);
  void onPeer(Peer& p, unsigned events);  // FdWatch events
  void welcome(Peer& p, std::string_view body);
  void refusePeer(Peer& p, const std::string& why);
  void closePeer(int fd, const std::string& why);
  void connectPath(Path& p, const std::string& endpoint);
  bool sendHello(Path& p);                      // false: the path failed
  void onPathSocket(Path& p, unsigned events);  // FdWatch events
  void onPathEvent(Path& p);
  void pathFrames(Path& p);
  void failPath(uint16_t chan_id, const std::string& why);
  // A message of `bytes` delivered from `p`: in our statistics and in p's next report.
  void counted(Path& p, size_t bytes);
  // Tells the hub what came on `p` since the last report (PHYS_RECEIVED, a 1.10 hub).
  void report(Path& p);
  // Closes p's socket, polls and ring; a ring being read by a callback goes when it returns.
  void closePath(Path& p);
  // Whether `p` is still the path of `chan_id` (a callback may have unsubscribed or reset it).
  [[nodiscard]] bool alive(uint16_t chan_id, const Path* p) const;
  // `after`: the owner's last message relayed; none: drop what waits on the path (1.8).
  void onMarker(Path& p, std::optional<uint64_t> after);
  void readRing(Path& p);
  // After a message from a woken ring: poll it for kLingerNs more if it came in a stream
  // (`skipped`: older ones were skipped to read it).
  void linger(Path& p, bool skipped);
  // Polls spinning rings on every turn of the loop while one works (the loop then never sleeps).
  void updateSpin();
  void spinOnce();
  void request(Path& p);

  Host host_;
  int listen_fd_ = -1;
  FdWatch listen_watch_;
  std::string listen_path_;
  int tcp_fd_ = -1;
  FdWatch tcp_watch_;
  std::string tcp_endpoint_;                            // "tcp:<address>:<port>" once listening
  std::map<uint16_t, std::unique_ptr<Served>> served_;  // by channel id
  std::map<std::string, flow::shm::RingWriter> idle_rings_;  // channels not created now
  struct Grant {
    uint16_t chan_id = 0;
    uint32_t subscriber = 0;
    uint8_t path = 0;
    Nanos expires = 0;
  };
  std::map<std::string, Grant> grants_;         // by token
  std::map<int, std::unique_ptr<Peer>> peers_;  // by socket
  struct Wanted {
    uint8_t kinds = 0;
    bool spin = false;
  };
  std::map<std::string, Wanted, std::less<>> wanted_;  // by full name
  std::map<uint16_t, std::unique_ptr<Path>> paths_;    // by channel id
  Stats stats_;
  Spinner spin_;                                           // made when a ring is first polled
  const Path* reading_ = nullptr;                          // a ring callback runs for it
  std::unique_ptr<flow::shm::RingReader> retired_reader_;  // closed during that callback
};

}  // namespace skr::flow::phys
