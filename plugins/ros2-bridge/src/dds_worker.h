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

struct BridgeEvent {
  enum class Kind : std::uint8_t { sample, matched, incompatible_qos, malformed, dropped };
  Kind kind = Kind::sample;
  bool import = true;  // which list `item` indexes: the config's imports or exports
  std::size_t item = 0;
  std::string payload;       // sample: what the channel publishes
  std::int32_t matched = 0;  // matched: the endpoints matched now
  std::string text;          // incompatible_qos: the policy; malformed: why; dropped: where
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
  // What waits for the loop, oldest first.
  [[nodiscard]] std::vector<BridgeEvent> take();
  [[nodiscard]] std::string participantGuid() const;

 private:
  struct Op {
    bool import = false;  // true: a sample read from an imported topic; false: a write
    std::size_t item = 0;
    std::string bytes;
    std::string writer_guid;
  };
  void run(std::promise<Result<void>>& started);
  Result<void> createEndpoints();
  Result<void> publishGraph();
  bool enqueue(Op op);
  void emit(BridgeEvent ev);
  void handle(Op& op);

  const BridgeConfig& config_;
  const ros2::Registry& registry_;
  std::function<void()> wake_;
  std::unique_ptr<DdsParticipant> participant_;  // the DDS thread's
  std::vector<EndpointId> readers_, writers_;    // by import and export item
  std::string own_prefix_;                       // this participant's GUID prefix

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
