// SPDX-License-Identifier: Apache-2.0
// ros2-bridge's DDS thread (docs/internals.md, "ros2-bridge's threads"): it owns the participant
// and its endpoints, converts samples between CDR and JSON, and writes. The loop hands it the
// exported channels' messages (write()); Fast DDS's threads hand it the imported topics' samples;
// what the loop must hear (samples to publish, matches, QoS problems, errors) waits in an outbox
// that the loop empties with take() after `wake` (called on the DDS thread or Fast DDS's, when the
// outbox turns non-empty). Both queues are bounded by BridgeConfig::queue_bytes; what does not fit
// is dropped and counted.
#pragma once

#include "bridge_config.h"

#include <skrobot/ros2/definitions.h>

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace skr::ros2_bridge {

// Which list of the config an event's or operation's `item` indexes.
enum class ItemList : std::uint8_t { imports, exports, service_imports, service_exports };

struct BridgeEvent {
  enum class Kind : std::uint8_t {
    sample,            // imports: `payload` to publish, from the writer `text` (its GUID)
    matched,           // `matched` endpoints now (services: of the request endpoint); imports:
                       // `text` the GUID of a writer that went
    incompatible_qos,  // `text`: the policy
    malformed,         // `text`: why (the sample or message is dropped)
    dropped,           // `text`: where (a queue, a failed write)
    request,           // service_exports: a ROS 2 client's request, `payload` JSON, `identity`
    sent,              // service_imports: the request of `tag` went out as `identity`
    reply,             // service_imports: the reply `payload` (JSON) to `identity.sequence`
    failed,            // service_imports: the request of `tag` could not go out (`text`)
  };
  BridgeEvent() = default;
  BridgeEvent(Kind k, ItemList l, std::size_t i, std::string p = {}, std::int32_t m = 0,
              std::string t = {}, SampleIdentity id = {}, std::uint64_t g = 0)
      : kind(k),
        list(l),
        item(i),
        payload(std::move(p)),
        matched(m),
        text(std::move(t)),
        identity(id),
        tag(g) {}

  Kind kind = Kind::sample;
  ItemList list = ItemList::imports;
  std::size_t item = 0;
  std::string payload;
  std::int32_t matched = 0;
  std::string text;
  SampleIdentity identity;
  std::uint64_t tag = 0;
};

class DdsWorker {
 public:
  // `registry` must outlive the worker (read from its thread).
  DdsWorker(const BridgeConfig& config, const ros2::Registry& registry, std::function<void()> wake);
  ~DdsWorker();  // stop()
  DdsWorker(const DdsWorker&) = delete;
  DdsWorker& operator=(const DdsWorker&) = delete;

  // Starts the thread, which creates the participant and every endpoint; waits for it. The error
  // names what failed ("ROS2-NOT-CONFINED ...", a topic's endpoint).
  [[nodiscard]] Result<void> start();
  // Deletes the endpoints and the participant on the DDS thread and joins it: no wake after.
  void stop();

  // An exported channel's message for export `item` (loop thread): converted and written on the
  // DDS thread. False when the queue is full (dropped).
  bool write(std::size_t item, std::string_view payload);
  // An export made while the bridge runs (a channel that a pattern matched; loop thread): its
  // item number, after the config's exports and those added before. Its writer is made on the
  // DDS thread (a failure comes back as a `malformed` event of the item); removeExport deletes
  // it. The graph information follows both.
  std::size_t addExport(TopicItem item);
  void removeExport(std::size_t item);
  // Whether the hub reads import `item` (its channel has subscribers; loop thread): its reader
  // exists while it does (a transient_local import's always).
  void setReading(std::size_t item, bool reading);
  // service_exports: the hub's answer to a ROS 2 client's request (`ok` false: `value_json` is
  // why), written as the reply to `request`.
  void reply(std::size_t item, const SampleIdentity& request, bool ok, std::string value_json);
  // service_imports: a hub request (`tag`) for the ROS 2 server, its value JSON.
  void request(std::size_t item, std::uint64_t tag, std::string value_json);
  // What waits for the loop, oldest first.
  [[nodiscard]] std::vector<BridgeEvent> take();
  [[nodiscard]] std::string participantGuid() const;

 private:
  struct Op {
    enum class Kind : std::uint8_t {
      imported,       // a sample of an imported topic
      write,          // an exported channel's message
      request,        // service_exports: a ROS 2 request read; service_imports: a hub request
      reply,          // service_exports: the hub's answer; service_imports: a ROS 2 reply read
      add_export,     // `topic` becomes export `item`
      remove_export,  // export `item` goes
      start_reading,  // import `item`'s reader is made
      stop_reading,   // and deleted
    };
    Op() = default;
    Op(Kind k, ItemList l, std::size_t i, std::string b)
        : kind(k), list(l), item(i), bytes(std::move(b)) {}

    Kind kind = Kind::write;
    ItemList list = ItemList::imports;
    std::size_t item = 0;
    std::string bytes;
    std::string writer_guid;
    SampleIdentity identity, related;
    std::uint64_t tag = 0;
    bool ok = true;
    TopicItem topic;  // add_export
  };
  struct ServiceEndpoints {
    EndpointId requests = 0;  // a reader (exports) or a writer (imports)
    EndpointId replies = 0;   // a writer (exports) or a reader (imports)
  };
  void handleService(Op& op);
  void changeExports(Op& op);
  void changeReading(Op& op);
  // A message of `type` from JSON, and a CDR sample checked against `type` (moved out).
  [[nodiscard]] Result<std::string> fromJson(const std::string& type,
                                             const std::string& json) const;
  [[nodiscard]] Result<std::string> checked(const std::string& type, std::string& cdr) const;
  void run(std::promise<Result<void>>& started);
  Result<void> createEndpoints();
  Result<EndpointId> createImportReader(std::size_t item);
  Result<EndpointId> createExportWriter(std::size_t item);
  Result<void> publishGraph();
  bool enqueue(Op op);
  void emit(BridgeEvent ev);
  void handle(Op& op);

  const BridgeConfig& config_;
  const ros2::Registry& registry_;
  std::function<void()> wake_;
  std::unique_ptr<DdsParticipant> participant_;  // the DDS thread's
  std::vector<TopicItem> exports_;               // the DDS thread's: the config's, then added
  std::vector<EndpointId> readers_, writers_;    // by import and export item (0: none)
  EndpointId graph_ = 0;                         // ros_discovery_info's writer
  std::size_t next_export_ = 0;                  // the loop's: addExport's next item
  std::vector<ServiceEndpoints> service_imports_, service_exports_;
  std::string own_prefix_;             // this participant's GUID prefix
  std::vector<std::uint64_t> frames_;  // media imports: the next frame's seq, by item

  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Op> ops_;
  std::size_t ops_bytes_ = 0;
  std::vector<BridgeEvent> outbox_;
  std::size_t outbox_bytes_ = 0;
  bool stopping_ = false;
  std::string guid_;
  std::thread thread_;
};

}  // namespace skr::ros2_bridge
