// SPDX-License-Identifier: Apache-2.0
// A satellite on a skr::Loop: the flow (one asynchronous connection to the hub) as an skr::Object
// that emits typed signals, with channels, publishing, services and databases.
//
//   skr::Loop loop;
//   skr::sat::Satellite sat(loop, skr::sat::SatelliteOptions::fromEnvironment("viewer").value());
//   sat.data.connect(&sat, [&](uint16_t id, const std::string& payload) { ... });
//   sat.subscribe("guest.camera");      // by name: waits for the channel to appear
//   sat.start();
//   loop.run();
//
// Threading: a Satellite belongs to the loop it was created with. Create it, call its methods and
// destroy it on that loop's thread. Its socket is a libuv stream on loop.uv(); nothing here blocks
// except the methods marked BLOCKING, which use a separate synchronous connection (so the flow
// is never blocked, but the calling loop thread waits).
//
// Signals are emitted on the loop thread while the satellite handles a frame. A slot may call
// any method, stop() included, but must not destroy the satellite (use skr::deleteLater).
// Connect slots before start(): connections take effect at the loop's next pulse.
//
// SIGPIPE: a hub that closes the connection while the satellite writes would kill the process
// by SIGPIPE's default action; the library sets SIGPIPE to ignored when its first connection is
// made, unless the process chose a disposition of its own.
//
// Reconnection: when the link drops, the hub restarts, or the hub breaks the protocol, the
// satellite closes the connection (logging why), emits `disconnected`, and retries with a backoff
// (100 ms doubling to 2 s). Once logged in again it re-creates its channels (same short names and
// properties), re-subscribes by name, re-selects its flow database and emits `connected`, then
// `channelReady` / `subscribed` with the new ids.
#pragma once

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/shm_ring.h>
#include <skrobot/runtime/object.h>
#include <skrobot/runtime/signal.h>
#include <skrobot/satellite/sync_client.h>

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace skr::sat {

struct SatelliteOptions {
  ConnectOptions connection;
  bool reconnect = true;  // false: stay disconnected after the first loss
  // Delays between connection attempts, whatever ended the last one (refused, closed by the
  // hub, a frame that breaks the protocol): reconnect_min_ns, doubled after each attempt up to
  // reconnect_max_ns. Back to reconnect_min_ns only after a flow that stayed open for
  // reconnect_reset_after_ns, so a hub that accepts the login and then drops us is not stormed.
  Nanos reconnect_min_ns = 100 * kNsPerMs;
  Nanos reconnect_max_ns = 2 * kNsPerSec;
  Nanos reconnect_reset_after_ns = 5 * kNsPerSec;
  Nanos handshake_timeout_ns = 10 * kNsPerSec;  // connect + login + GO_ASYNC
  size_t max_queued_bytes = 8u << 20;  // outgoing bytes waiting; publish() fails beyond this
  // Physical mode's direct paths to subscribers on other machines (docs/physical-mode.md):
  // "<address they reach us at>:<port>" (IPv4, or IPv6 in brackets: "[fd00::20]:0"; port 0:
  // any free one) to listen on besides our Unix socket. Unencrypted, like the data it carries:
  // for a trusted network. fromEnvironment() reads ROBOT_PATH_TCP.
  std::string path_tcp;
  // Set only by a hub that links to another (docs/hub-links.md): its own hub name, said in
  // HUB_LINK_HELLO after each login (FlowProtocol 1.5). A refusal is a refused login.
  std::string hub_name;

  // ConnectOptions::fromEnvironment() with the defaults above.
  [[nodiscard]] static Result<SatelliteOptions> fromEnvironment(std::string client_name = {});
};

// Physical mode for one of our streaming channels (docs/physical-mode.md, FlowProtocol 1.7):
// subscribers the hub allows may read it straight from us, over a socket of ours or, on this
// machine, from shared memory; the others still get it through the hub.
struct PhysicalOptions {
  bool direct = false;  // a Unix socket of ours (the hub hands out one-time tokens)
  bool shm = false;     // a ring of slots in shared memory (ring.slot_bytes: the largest message)
  flow::shm::RingGeometry ring{};
};

// Path kinds a subscriber asks for (usePaths).
inline constexpr uint8_t kPathDirect = 1, kPathShm = 2;
// How a subscriber waits for its shared-memory path (usePaths). wake: the owner's eventfd wakes
// its loop (which sleeps meanwhile). spin: while such a path works the loop never sleeps and
// looks at the ring on each turn, so that a message does not wait for a wake-up (docs/
// physical-mode.md has the figures); it costs a core for as long. Direct paths are always woken.
enum class PathWait : uint8_t { wake, spin };

// A channel this satellite owns, "<user>.<name>".
struct ChannelSpec {  // NOLINT(bugprone-exception-escape): Variant moves do not throw
  std::string name;   // the short name: 1-128 of A-Z a-z 0-9 _ - . (not starting with '.')
  flow::ChannelKind kind = flow::ChannelKind::streaming;
  std::string mime = {};                       // what the payloads are, e.g. "image/jpeg"
  flow::Variant props = flow::Variant::Map{};  // the channel's database (sample rate, size, ...)
  PhysicalOptions physical = {};               // streaming channels only
};

// A request to one of our service channels: answer with respond(request, value).
using Request = flow::msg::EvServiceRequest;
// The answer to request(); `error` is ok, or why it failed (value then holds a message).
struct Response {  // NOLINT(bugprone-exception-escape): Variant moves do not throw
  uint16_t chan_id = 0;
  uint32_t tag = 0;
  flow::ErrorCode error = flow::ErrorCode::ok;
  flow::Variant value;
  [[nodiscard]] bool ok() const noexcept { return error == flow::ErrorCode::ok; }
  // The error as the Errc a module would get for the same failure (flow::toErrc).
  [[nodiscard]] Errc errc() const noexcept { return flow::toErrc(error); }
};
// A file of a subscribed blob channel changed (EV_BLOB_CHANGED, docs/blob-channels.md).
struct BlobChange {
  uint16_t chan_id = 0;
  flow::msg::BlobChange change = flow::msg::BlobChange::written;
  std::string path;
  uint64_t size = 0;
  uint64_t version = 0;
};
// A pulse of a sync source we follow (EV_SYNC_PULSE, docs/sync-pulse.md). `dropped`: pulses the
// hub dropped for us since the previous one because our handling of that one was not done.
struct SyncPulse {
  uint16_t chan_id = 0;
  uint64_t seq = 0;
  uint64_t source_time_ns = 0;  // the source's CLOCK_MONOTONIC (comparable on one machine)
  uint32_t dropped = 0;
  Nanos arrival_ns = 0;  // our CLOCK_MONOTONIC when it arrived
};
// A clock probe's answer (TIME_PROBE, FlowProtocol 1.5): the hub's wall clock against ours,
// with four CLOCK_REALTIME timestamps in ns as NTP takes them (t1 sent, t2 the hub got it, t3 the
// hub answered, t4 the answer arrived).
struct TimeSample {
  uint32_t tag = 0;
  int64_t t1 = 0, t2 = 0, t3 = 0, t4 = 0;
  [[nodiscard]] int64_t roundTripNs() const noexcept { return (t4 - t1) - (t3 - t2); }
  // The hub's clock minus ours: add it to one of our wall-clock times to get the hub's.
  [[nodiscard]] int64_t offsetNs() const noexcept { return ((t2 - t1) + (t3 - t4)) / 2; }
};
// A command the hub refused (EV_ERROR: `command` and `tag` name it), a refused login (command
// LOGIN), or a local failure (command 0): protocol_error when the hub broke the protocol,
// io_error when the first connection failed and `reconnect` is off.
using FlowError = flow::msg::EvError;

struct SatelliteStats {
  uint64_t connections = 0;  // successful logins
  uint64_t frames_in = 0;
  uint64_t frames_out = 0;
  uint64_t writes = 0;        // write calls: frames_out / writes is the batching
  uint64_t data_dropped = 0;  // data frames the hub dropped for us (EV_DROPPED)
  uint64_t protocol_errors = 0;
  uint64_t slot_exceptions = 0;  // exceptions thrown by slots connected to our signals (logged)
};

class Satellite : public Object {
 public:
  using ResponseHandler = std::function<void(const Response&)>;

  // Does not connect yet: start() does.
  Satellite(Loop& loop, SatelliteOptions options);
  ~Satellite() override;  // closes the flow; pending request handlers are not called
  Satellite(const Satellite&) = delete;
  Satellite& operator=(const Satellite&) = delete;
  Satellite(Satellite&&) = delete;
  Satellite& operator=(Satellite&&) = delete;

  // Starts connecting, and returns at once. Idempotent.
  void start();
  // Closes the flow and stops reconnecting; start() connects again. Idempotent.
  void stop();

  [[nodiscard]] bool isConnected() const noexcept;  // logged in, flow open
  [[nodiscard]] const SatelliteOptions& options() const noexcept;
  [[nodiscard]] const LoginInfo& login() const noexcept;  // from the last login
  [[nodiscard]] const std::string& user() const noexcept { return login().user; }
  [[nodiscard]] const SatelliteStats& stats() const noexcept;
  // The far hub's name, when options().hub_name made this connection a hub link.
  [[nodiscard]] const std::string& linkedHub() const noexcept;

  // --- channels ------------------------------------------------------------------------------
  // Declares a channel of ours: created now when connected, and after every reconnection;
  // `channelReady` gives its id each time. Errc::already_exists when declared already,
  // Errc::invalid_argument for a bad name. The hub may still refuse it (`error` signal).
  // A blob channel (kind blob, protocol 1.3) outlives this satellite on the hub: adding it again
  // gives back the same channel with its files, which syncClient() reads and writes.
  [[nodiscard]] Result<void> addChannel(ChannelSpec spec);
  // Removes one of ours (by short name). Errc::not_found.
  [[nodiscard]] Result<void> removeChannel(std::string_view name);
  // Merges keys into one of our channels' properties (a null value removes a key); everyone gets
  // `channelChanged`. Kept for re-creation.
  [[nodiscard]] Result<void> setChannelProperties(std::string_view name, flow::Variant::Map props);

  // A channel as the hub describes it now: by id, by full name, or by the short name of one of
  // ours. nullptr (nullopt) when it does not exist now. Pointers last until the next event.
  [[nodiscard]] const ChannelInfo* channel(uint16_t chan_id) const;
  [[nodiscard]] const ChannelInfo* channel(std::string_view name) const;
  [[nodiscard]] std::optional<uint16_t> channelId(std::string_view name) const;
  [[nodiscard]] std::vector<ChannelInfo> channels() const;  // every channel of the hub now
  // Whether one of our streaming channels has subscribers now (start/stop publish).
  [[nodiscard]] bool hasSubscribers(std::string_view name) const;

  // Subscribes by full name ("<user>.<name>"): at once when the channel exists, else as soon as
  // it appears; kept when the channel is re-created and across reconnections. Idempotent.
  void subscribe(std::string name);
  // The same, asking the hub for a queue of `queue_bytes` for this subscription (FlowProtocol
  // 1.13, docs/cpp-satellites.md "Queue sizes for video"): what the hub holds for us before it
  // drops our oldest data. The hub clamps it to its server.subscriber_queue_max_bytes and then
  // emits `error` (SUBSCRIBE_QUEUE, limit_exceeded, what it granted): we stay subscribed. Our
  // queue is the larger of the hub's default and every such grant; 0 asks for the default. A
  // hub older than 1.13 gives the default. Called again, it changes the request.
  void subscribe(std::string name, size_t queue_bytes);
  // Subscribes to the channel that has this id now (kept by its name, as above).
  [[nodiscard]] Result<void> subscribe(uint16_t chan_id);
  void unsubscribe(std::string_view name);
  [[nodiscard]] bool isSubscribed(std::string_view name) const;  // attached to the channel now

  // Asks the hub to mirror the streaming channel `source` (a linked hub's, typically) as our
  // channel "<user>.<short_name>" (docs/hub-links.md, "Replicas"): the hub subscribes to the
  // source while the replica has subscribers and copies its properties. Kept while this
  // satellite's flow lasts, and asked again after each reconnection; a refusal comes as the
  // `error` signal with the returned tag. Errc::closed, Errc::unsupported (a hub older than 1.5).
  [[nodiscard]] Result<uint32_t> replicate(std::string source, std::string short_name);
  [[nodiscard]] Result<uint32_t> stopReplica(std::string_view short_name);

  // --- the sync pulse (FlowProtocol 1.4, docs/sync-pulse.md) ---------------------------------
  // Follows the sync source `name` ("<user>.<name>"), every `every`th pulse: `syncPulse` is
  // emitted for each, and the hub learns that we are done with it when the signal's slots have
  // returned (pulses that come meanwhile are dropped and counted). Kept like a subscription by
  // name: across re-creations and reconnections. unfollow() with the same name stops it.
  void follow(std::string name, uint32_t every = 1);
  void unfollow(std::string_view name);
  // A pulse of one of our sync sources (addChannel with kind sync), stamped with the monotonic
  // clock now. Errc::closed, Errc::not_found (no such source of ours yet).
  [[nodiscard]] Result<void> pulse(std::string_view name);

  // Publishes on one of our streaming channels. Queued: everything queued during one loop
  // iteration goes out in one write. Errc::closed (not connected), Errc::not_found (no such
  // channel of ours yet), Errc::limit_exceeded (max_queued_bytes wait: the frame is dropped).
  [[nodiscard]] Result<void> publish(uint16_t chan_id, std::string_view payload);
  [[nodiscard]] Result<void> publish(std::string_view name, std::string_view payload);
  [[nodiscard]] size_t queuedBytes() const noexcept;  // written soon, or being written
  // Zero-copy publishing on a channel with a shared-memory ring: the slot to fill in place
  // (empty when the channel has no ring, or every slot is being read: then publish() instead),
  // then its commit, which also sends the bytes to direct subscribers and, when someone is
  // relayed, to the hub. `capture_ns` travels with the message on the paths.
  [[nodiscard]] std::span<std::byte> beginPublish(std::string_view name);
  [[nodiscard]] Result<void> commitPublish(std::string_view name, size_t size,
                                           int64_t capture_ns = 0);

  // Physical mode as a subscriber: ask the hub for a path of these kinds (kPathShm, kPathDirect)
  // whenever we are subscribed to `name`; data then comes straight from the owner (the same
  // `data` and `dataView` signals), and through the hub again whenever the path breaks (asked
  // again with a backoff). 0: relayed only. Needs FlowProtocol 1.7; an older hub relays.
  void usePaths(std::string name, uint8_t kinds = kPathShm | kPathDirect);
  // The same, saying how a shared-memory path is waited for (PathWait; the above wakes).
  void usePaths(std::string name, uint8_t kinds, PathWait wait);
  struct PathStats {
    uint64_t served_direct = 0, served_shm = 0;  // subscribers on our paths now
    uint64_t path_messages = 0;                  // received on paths
    uint64_t dropped_before_marker = 0, torn = 0, fallbacks = 0;
    uint64_t missed = 0;  // shared memory: published while we were busy, never read (newest wins)
    uint64_t polled = 0;  // shared memory, woken: read while polling in a stream, without a wake-up
  };
  [[nodiscard]] PathStats pathStats() const;
  // Closes every path of ours, both sides, as if they broke: subscribers fall back to the relay
  // and ask again after a second. For tests, and for a process that must let go of its sockets.
  void resetPaths();

  // --- services ------------------------------------------------------------------------------
  // An asynchronous request to a service channel (by name or id). The answer comes as the
  // `serviceResponse` signal and to `done`, matched by the returned tag; a lost connection
  // answers with error io_error; no answer within `timeout_ms` (0: the hub's
  // server.request_timeout_ms) answers with error timeout. Errc::closed, Errc::not_found (no
  // such channel now), Errc::unsupported (a timeout asked of a hub older than 1.4).
  [[nodiscard]] Result<uint32_t> request(std::string_view service, const std::string& command,
                                         const flow::Variant& value, ResponseHandler done = {},
                                         uint32_t timeout_ms = 0);
  [[nodiscard]] Result<uint32_t> request(uint16_t chan_id, const std::string& command,
                                         const flow::Variant& value, ResponseHandler done = {},
                                         uint32_t timeout_ms = 0);
  // Answers a request made to one of our service channels.
  [[nodiscard]] Result<void> respond(const Request& request, const flow::Variant& value);
  // BLOCKING: a synchronous service call over the synchronous connection (see SyncClient::call).
  // Never call one of this satellite's own services this way: nobody would answer it.
  [[nodiscard]] Result<flow::Variant> call(std::string_view service, const std::string& command,
                                           const flow::Variant& value, uint32_t timeout_ms = 5000);

  // --- databases -----------------------------------------------------------------------------
  // BLOCKING reads over the synchronous connection. `db` empty: the user's database.
  [[nodiscard]] Result<flow::Variant> get(const std::string& key, const std::string& db = {});
  [[nodiscard]] Result<flow::Variant::Map> getAll(const std::string& db = {});
  [[nodiscard]] Result<std::vector<std::string>> keys(const std::string& db = {});
  // Writes on the flow (asynchronous; a refusal comes as the `error` signal with the returned
  // tag). `db` empty: the flow's current database (the user's, unless selectDatabase()).
  [[nodiscard]] Result<uint32_t> set(const std::string& key, const flow::Variant& value,
                                     const std::string& db = {});
  [[nodiscard]] Result<uint32_t> del(const std::string& key, const std::string& db = {});
  [[nodiscard]] Result<uint32_t> createDatabase(const std::string& name);
  [[nodiscard]] Result<uint32_t> saveDatabase(const std::string& name = {});
  // A barrier for the writes above, which have no reply: `databasesSynced` is emitted with the
  // returned tag once every change this flow sent before it is on disk (a failure comes as the
  // `error` signal with the tag). Protocol 1.2; an older hub answers unsupported.
  [[nodiscard]] Result<uint32_t> syncDatabases();
  // Reads database `db` on the flow, without blocking (FlowProtocol 1.6): any database the user
  // may read, a linked hub's as "<hub>/<name>". `done` gets the value (get: the key's; all: a
  // map of every pair; keys: a sorted list) or the error (the value then holds a message); a
  // lost connection answers io_error. Errc::closed, Errc::unsupported (a hub older than 1.6).
  [[nodiscard]] Result<uint32_t> readDatabase(const std::string& db, flow::msg::DbReadWhat what,
                                              const std::string& key, ResponseHandler done);
  // --- a hub's own link (docs/hub-links.md, "One connection"): FlowProtocol 1.6, on a link whose
  // far hub sent `linkWanted`. Offers a channel of this hub under its name here ("<user>.<name>",
  // or "<hub>/<user>.<name>" for a third hub's); the far hub makes it ours (`channelAdded`, owner
  // our connection), or refuses it (the `error` signal with the returned tag). Our offered
  // channels are then published, answered, changed (by id) and withdrawn like our own.
  [[nodiscard]] Result<uint32_t> offerChannel(const ChannelInfo& channel);
  [[nodiscard]] Result<void> withdrawChannel(uint16_t chan_id);
  [[nodiscard]] Result<void> setChannelProperties(uint16_t chan_id, flow::Variant::Map props);

  // Probes the hub's wall clock: `timeSample` comes with the returned tag. Errc::closed,
  // Errc::unsupported (a hub older than FlowProtocol 1.5).
  [[nodiscard]] Result<uint32_t> probeTime();
  // The flow's current database from now on (and after reconnections).
  [[nodiscard]] Result<uint32_t> selectDatabase(const std::string& name);
  // BLOCKING: the synchronous connection itself, opened (or re-opened) as needed; valid until
  // the next BLOCKING call or the satellite's destruction.
  [[nodiscard]] Result<SyncClient*> syncClient();

  // --- signals (emitted on the loop thread) ---------------------------------------------------
  Signal<> connected{*this};                       // logged in, flow open (after each connection)
  Signal<const std::string&> disconnected{*this};  // why; ids are void until connected again
  Signal<const ChannelInfo&> channelReady{*this};  // one of ours was created: its id
  Signal<const ChannelInfo&> subscribed{*this};    // a subscription by name attached: the id
  Signal<const ChannelInfo&> channelAdded{*this};
  Signal<const ChannelInfo&> channelRemoved{*this};
  Signal<const ChannelInfo&> channelChanged{*this};  // properties (EV_CHAN_HEADER)
  Signal<uint16_t> startPublish{*this};              // first subscriber of one of ours
  Signal<uint16_t> stopPublish{*this};               // last subscriber left
  Signal<uint16_t, const std::string&> data{*this};  // chan_id, payload
  // The same payload in place, without the copy `data` makes (emitted first; `data` only when
  // something is connected to it). The view is valid during the slot only: connect directly,
  // on the satellite's loop thread, never queued to another thread.
  Signal<uint16_t, std::string_view> dataView{*this};
  Signal<const Request&> serviceRequest{*this};
  Signal<const Response&> serviceResponse{*this};
  Signal<const FlowError&> error{*this};
  Signal<uint32_t> databasesSynced{*this};       // the tag of syncDatabases()
  Signal<const TimeSample&> timeSample{*this};   // the answer to probeTime()
  Signal<const std::string&> linkWanted{*this};  // the far hub (its name) wants our offers
  // A file of a blob channel we subscribe to was written or removed (subscribe() by its name);
  // its files are read and written through syncClient() (SyncClient::blobGet, blobPut, ...).
  Signal<const BlobChange&> blobChanged{*this};
  Signal<const SyncPulse&> syncPulse{*this};  // a pulse of a source we follow

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace skr::sat
