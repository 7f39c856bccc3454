// SPDX-License-Identifier: Apache-2.0
#include "dds_worker.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/support/json.hpp>

namespace skr::ros2_bridge {

namespace {

// What a queued sample or event costs against queue_bytes: its bytes and a little more.
std::size_t cost(std::size_t bytes) {
  return bytes + 64;
}

std::string prefixOf(const std::string& guid) {
  return guid.substr(0, guid.find('|'));
}

}  // namespace

DdsWorker::DdsWorker(const BridgeConfig& config, const ros2::Registry& registry,
                     std::function<void()> wake)
    : config_(config), registry_(registry), wake_(std::move(wake)) {}

DdsWorker::~DdsWorker() {
  stop();
}

Result<void> DdsWorker::start() {
  std::promise<Result<void>> started;
  auto result = started.get_future();
  thread_ = std::thread([this, &started] { run(started); });
  Result<void> r = result.get();
  if (!r) stop();
  return r;
}

void DdsWorker::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void DdsWorker::run(std::promise<Result<void>>& started) {
  auto created = DdsParticipant::create(config_.participant);
  if (!created) {
    started.set_value(created.error());
    return;
  }
  participant_ = std::move(*created);
  {
    std::lock_guard lock(mutex_);
    guid_ = participant_->guid();
  }
  own_prefix_ = prefixOf(guid_);
  if (auto r = createEndpoints(); !r) {
    participant_.reset();
    started.set_value(r);
    return;
  }
  started.set_value(Result<void>{});  // `started` is gone after this
  for (;;) {
    Op op;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stopping_ || !ops_.empty(); });
      if (stopping_) break;
      op = std::move(ops_.front());
      ops_.pop_front();
      ops_bytes_ -= cost(op.bytes.size());
    }
    handle(op);
  }
  participant_.reset();  // joins Fast DDS's threads of this participant: no callback after
}

Result<void> DdsWorker::createEndpoints() {
  for (std::size_t i = 0; i < config_.imports.size(); ++i) {
    const TopicItem& t = config_.imports[i];
    ReaderCallbacks cb;
    cb.on_sample = [this, i](Sample&& s) {
      enqueue(Op{true, i, std::move(s.bytes), std::move(s.writer_guid)});
    };
    cb.on_matched = [this, i](const MatchStatus& m) {
      emit({BridgeEvent::Kind::matched, true, i, {}, m.current, {}});
    };
    cb.on_incompatible_qos = [this, i](const IncompatibleQos& q) {
      emit({BridgeEvent::Kind::incompatible_qos, true, i, {}, 0, q.policy});
    };
    auto id = participant_->createReader(t.ros, t.type, t.qos, std::move(cb));
    if (!id) return makeError(id.error().code, "import " + t.ros + ": " + id.error().message);
    readers_.push_back(*id);
  }
  for (std::size_t i = 0; i < config_.exports.size(); ++i) {
    const TopicItem& t = config_.exports[i];
    WriterCallbacks cb;
    cb.on_matched = [this, i](const MatchStatus& m) {
      emit({BridgeEvent::Kind::matched, false, i, {}, m.current, {}});
    };
    cb.on_incompatible_qos = [this, i](const IncompatibleQos& q) {
      emit({BridgeEvent::Kind::incompatible_qos, false, i, {}, 0, q.policy});
    };
    auto id = participant_->createWriter(t.ros, t.type, t.qos, std::move(cb));
    if (!id) return makeError(id.error().code, "export " + t.ros + ": " + id.error().message);
    writers_.push_back(*id);
  }
  return publishGraph();
}

Result<void> DdsWorker::publishGraph() {
  // The bridge as a ROS 2 node with its readers and writers (ros2 node list, ros2 node info);
  // transient_local, so that tools started later read it.
  auto graph = participant_->createDdsWriter(kGraphTopic, kGraphType, graphQos());
  if (!graph) return makeError(graph.error().code, "ros_discovery_info: " + graph.error().message);
  std::vector<Gid> readers, writers;
  for (EndpointId id : readers_) readers.push_back(participant_->gid(id));
  for (EndpointId id : writers_) writers.push_back(participant_->gid(id));
  std::string sample;
  try {
    sample = participantEntitiesInfo(config_.distribution, participant_->participantGid(),
                                     config_.ns, config_.node, readers, writers);
  } catch (const std::exception& e) {
    return makeError(Errc::invalid_argument, std::string("ros_discovery_info: ") + e.what());
  }
  return participant_->write(*graph, sample);
}

bool DdsWorker::write(std::size_t item, std::string_view payload) {
  return enqueue(Op{false, item, std::string(payload), {}});
}

bool DdsWorker::enqueue(Op op) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return false;
    if (ops_bytes_ + cost(op.bytes.size()) > config_.queue_bytes) {
      // Counted on the loop, with the others (the event is small).
      outbox_.push_back({BridgeEvent::Kind::dropped, op.import, op.item, {}, 0, "queue"});
      const bool first = outbox_.size() == 1;
      if (first && wake_) wake_();
      return false;
    }
    ops_bytes_ += cost(op.bytes.size());
    ops_.push_back(std::move(op));
  }
  cv_.notify_one();
  return true;
}

void DdsWorker::emit(BridgeEvent ev) {
  bool first = false;
  {
    std::lock_guard lock(mutex_);
    const std::size_t c = cost(ev.payload.size());
    if (ev.kind == BridgeEvent::Kind::sample && outbox_bytes_ + c > config_.queue_bytes) {
      ev = {BridgeEvent::Kind::dropped, ev.import, ev.item, {}, 0, "outbox"};
    } else {
      outbox_bytes_ += c;
    }
    outbox_.push_back(std::move(ev));
    first = outbox_.size() == 1;
  }
  if (first && wake_) wake_();
}

std::vector<BridgeEvent> DdsWorker::take() {
  std::lock_guard lock(mutex_);
  outbox_bytes_ = 0;
  return std::exchange(outbox_, {});
}

std::string DdsWorker::participantGuid() const {
  std::lock_guard lock(const_cast<std::mutex&>(mutex_));
  return guid_;
}

void DdsWorker::handle(Op& op) {
  if (op.import) {
    const TopicItem& t = config_.imports[op.item];
    if (prefixOf(op.writer_guid) == own_prefix_) return;  // our own export of the same topic
    if (t.encoding == Encoding::cdr) {
      // Checked before the hub sees it: a sample that does not read as its type is dropped.
      if (auto v = ros2::validate(registry_, t.type, op.bytes); !v) {
        emit({BridgeEvent::Kind::malformed, true, op.item, {}, 0, v.error().message});
        return;
      }
      emit({BridgeEvent::Kind::sample, true, op.item, std::move(op.bytes), 0, {}});
    } else {
      auto v = ros2::cdrToJson(registry_, t.type, op.bytes);
      if (!v) {
        emit({BridgeEvent::Kind::malformed, true, op.item, {}, 0, v.error().message});
        return;
      }
      emit({BridgeEvent::Kind::sample, true, op.item, support::writeJson(*v), 0, {}});
    }
    return;
  }
  const TopicItem& t = config_.exports[op.item];
  std::string cdr;
  if (t.encoding == Encoding::json) {
    auto value = support::parseJson(op.bytes);
    if (!value) {
      emit({BridgeEvent::Kind::malformed,
            false,
            op.item,
            {},
            0,
            "not JSON: " + value.error().message});
      return;
    }
    auto sample = ros2::jsonToCdr(registry_, t.type, *value);
    if (!sample) {
      emit({BridgeEvent::Kind::malformed, false, op.item, {}, 0, sample.error().message});
      return;
    }
    cdr = std::move(*sample);
  } else {
    if (auto v = ros2::validate(registry_, t.type, op.bytes); !v) {
      emit({BridgeEvent::Kind::malformed, false, op.item, {}, 0, v.error().message});
      return;
    }
    cdr = std::move(op.bytes);
  }
  if (auto r = participant_->write(writers_[op.item], cdr); !r) {
    emit({BridgeEvent::Kind::dropped, false, op.item, {}, 0, r.error().message});
  }
}

}  // namespace skr::ros2_bridge
