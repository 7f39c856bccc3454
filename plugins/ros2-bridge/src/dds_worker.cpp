// SPDX-License-Identifier: Apache-2.0
#include "dds_worker.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/images.h>
#include <skrobot/support/json.hpp>

#include "ros_names.h"

#include <algorithm>
#include <chrono>

namespace skr::ros2_bridge {

namespace {

// What a queued sample or event costs against queue_bytes: its bytes and a little more.
std::size_t cost(std::size_t bytes) {
  return bytes + 64;
}

std::string prefixOf(const std::string& guid) {
  return guid.substr(0, guid.find('|'));
}

// The wall clock, as ROS 2 stamps and media frames' capture times count (ns since the epoch).
std::int64_t nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

DdsWorker::DdsWorker(const BridgeConfig& config, const ros2::Registry& registry,
                     std::function<void()> wake)
    : config_(config),
      registry_(registry),
      wake_(std::move(wake)),
      exports_(config.exports),
      next_export_(config.exports.size()) {}

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
  frames_.assign(config_.imports.size(), 0);
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
  // An import's reader exists while the hub reads its channel (setReading), but a
  // transient_local one's from the start: what its writers keep is read once, at once.
  readers_.assign(config_.imports.size(), 0);
  for (std::size_t i = 0; i < config_.imports.size(); ++i) {
    if (config_.imports[i].qos.durability != Durability::transient_local) continue;
    auto id = createImportReader(i);
    if (!id) return id.error();
    readers_[i] = *id;
  }
  for (std::size_t i = 0; i < exports_.size(); ++i) {
    auto id = createExportWriter(i);
    if (!id) return id.error();
    writers_.push_back(*id);
  }
  // Services, as rmw_fastrtps makes them: requests on rq/<name>Request, replies on
  // rr/<name>Reply, both with ROS 2's services profile.
  const Qos services = *qosProfile("services");
  for (std::size_t i = 0; i < config_.service_exports.size(); ++i) {
    const ServiceItem& t = config_.service_exports[i];
    auto topics = ddsServiceTopics(t.ros);
    if (!topics) return topics.error();
    ServiceEndpoints e;
    ReaderCallbacks cb;
    cb.on_sample = [this, i](Sample&& s) {
      Op op{Op::Kind::request, ItemList::service_exports, i, std::move(s.bytes)};
      op.identity = s.identity;
      op.related = s.related;
      enqueue(std::move(op));
    };
    cb.on_matched = [this, i](const MatchStatus& m) {
      emit({BridgeEvent::Kind::matched, ItemList::service_exports, i, {}, m.current});
    };
    auto requests = participant_->createDdsReader(
        topics->first, ros2::ddsTypeName(t.type + "_Request"), services, std::move(cb));
    if (!requests) return makeError(requests.error().code, t.ros + ": " + requests.error().message);
    auto replies = participant_->createDdsWriter(topics->second,
                                                 ros2::ddsTypeName(t.type + "_Response"), services);
    if (!replies) return makeError(replies.error().code, t.ros + ": " + replies.error().message);
    service_exports_.push_back({*requests, *replies});
  }
  for (std::size_t i = 0; i < config_.service_imports.size(); ++i) {
    const ServiceItem& t = config_.service_imports[i];
    auto topics = ddsServiceTopics(t.ros);
    if (!topics) return topics.error();
    WriterCallbacks wcb;
    wcb.on_matched = [this, i](const MatchStatus& m) {
      emit({BridgeEvent::Kind::matched, ItemList::service_imports, i, {}, m.current});
    };
    auto requests = participant_->createDdsWriter(
        topics->first, ros2::ddsTypeName(t.type + "_Request"), services, std::move(wcb));
    if (!requests) return makeError(requests.error().code, t.ros + ": " + requests.error().message);
    ReaderCallbacks cb;
    cb.on_sample = [this, i](Sample&& s) {
      Op op{Op::Kind::reply, ItemList::service_imports, i, std::move(s.bytes)};
      op.identity = s.identity;
      op.related = s.related;
      enqueue(std::move(op));
    };
    auto replies = participant_->createDdsReader(
        topics->second, ros2::ddsTypeName(t.type + "_Response"), services, std::move(cb));
    if (!replies) return makeError(replies.error().code, t.ros + ": " + replies.error().message);
    service_imports_.push_back({*requests, *replies});
  }
  return publishGraph();
}

Result<EndpointId> DdsWorker::createImportReader(std::size_t i) {
  const TopicItem& t = config_.imports[i];
  ReaderCallbacks cb;
  cb.on_sample = [this, i](Sample&& s) {
    Op op{Op::Kind::imported, ItemList::imports, i, std::move(s.bytes)};
    op.writer_guid = std::move(s.writer_guid);
    enqueue(std::move(op));
  };
  cb.on_matched = [this, i](const MatchStatus& m) {
    // A writer gone: what it kept is no longer the topic's (its retained message goes).
    emit({BridgeEvent::Kind::matched,
          ItemList::imports,
          i,
          {},
          m.current,
          m.change < 0 ? m.remote_guid : std::string()});
  };
  cb.on_incompatible_qos = [this, i](const IncompatibleQos& q) {
    emit({BridgeEvent::Kind::incompatible_qos, ItemList::imports, i, {}, 0, q.policy});
  };
  auto id = participant_->createReader(t.ros, t.type, t.qos, std::move(cb));
  if (!id) return makeError(id.error().code, "import " + t.ros + ": " + id.error().message);
  return id;
}

Result<EndpointId> DdsWorker::createExportWriter(std::size_t i) {
  const TopicItem& t = exports_[i];
  WriterCallbacks cb;
  cb.on_matched = [this, i](const MatchStatus& m) {
    emit({BridgeEvent::Kind::matched, ItemList::exports, i, {}, m.current});
  };
  cb.on_incompatible_qos = [this, i](const IncompatibleQos& q) {
    emit({BridgeEvent::Kind::incompatible_qos, ItemList::exports, i, {}, 0, q.policy});
  };
  auto id = participant_->createWriter(t.ros, t.type, t.qos, std::move(cb));
  if (!id) return makeError(id.error().code, "export " + t.ros + ": " + id.error().message);
  return id;
}

Result<void> DdsWorker::publishGraph() {
  // The bridge as a ROS 2 node with its readers and writers (ros2 node list, ros2 node info);
  // transient_local, so that tools started later read it; written again when exports come and go.
  if (graph_ == 0) {
    auto graph = participant_->createDdsWriter(kGraphTopic, kGraphType, graphQos());
    if (!graph) {
      return makeError(graph.error().code, "ros_discovery_info: " + graph.error().message);
    }
    graph_ = *graph;
  }
  std::vector<Gid> readers, writers;
  for (EndpointId id : readers_) {
    if (id != 0) readers.push_back(participant_->gid(id));
  }
  for (EndpointId id : writers_) {
    if (id != 0) writers.push_back(participant_->gid(id));
  }
  for (const auto& e : service_exports_) {
    readers.push_back(participant_->gid(e.requests));
    writers.push_back(participant_->gid(e.replies));
  }
  for (const auto& e : service_imports_) {
    writers.push_back(participant_->gid(e.requests));
    readers.push_back(participant_->gid(e.replies));
  }
  std::string sample;
  try {
    sample = participantEntitiesInfo(config_.distribution, participant_->participantGid(),
                                     config_.ns, config_.node, readers, writers);
  } catch (const std::exception& e) {
    return makeError(Errc::invalid_argument, std::string("ros_discovery_info: ") + e.what());
  }
  return participant_->write(graph_, sample);
}

bool DdsWorker::write(std::size_t item, std::string_view payload) {
  return enqueue(Op{Op::Kind::write, ItemList::exports, item, std::string(payload)});
}

std::size_t DdsWorker::addExport(TopicItem item) {
  Op op{Op::Kind::add_export, ItemList::exports, next_export_, {}};
  op.topic = std::move(item);
  enqueue(std::move(op));
  return next_export_++;
}

void DdsWorker::removeExport(std::size_t item) {
  enqueue(Op{Op::Kind::remove_export, ItemList::exports, item, {}});
}

void DdsWorker::setReading(std::size_t item, bool reading) {
  enqueue(
      Op{reading ? Op::Kind::start_reading : Op::Kind::stop_reading, ItemList::imports, item, {}});
}

void DdsWorker::reply(std::size_t item, const SampleIdentity& request, bool ok,
                      std::string value_json) {
  Op op{Op::Kind::reply, ItemList::service_exports, item, std::move(value_json)};
  op.identity = request;
  op.ok = ok;
  enqueue(std::move(op));
}

void DdsWorker::request(std::size_t item, std::uint64_t tag, std::string value_json) {
  Op op{Op::Kind::request, ItemList::service_imports, item, std::move(value_json)};
  op.tag = tag;
  if (!enqueue(std::move(op))) {
    emit(
        {BridgeEvent::Kind::failed, ItemList::service_imports, item, {}, 0, "queue full", {}, tag});
  }
}

bool DdsWorker::enqueue(Op op) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return false;
    const bool control = op.kind != Op::Kind::imported && op.kind != Op::Kind::write &&
                         op.kind != Op::Kind::request && op.kind != Op::Kind::reply;
    if (!control && ops_bytes_ + cost(op.bytes.size()) > config_.queue_bytes) {
      // Counted on the loop, with the others (the event is small).
      outbox_.push_back({BridgeEvent::Kind::dropped, op.list, op.item, {}, 0, "queue"});
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
      ev = {BridgeEvent::Kind::dropped, ev.list, ev.item, {}, 0, "outbox"};
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
  if (op.list == ItemList::service_imports || op.list == ItemList::service_exports) {
    handleService(op);
    return;
  }
  if (op.kind == Op::Kind::start_reading || op.kind == Op::Kind::stop_reading) {
    changeReading(op);
    return;
  }
  if (op.kind == Op::Kind::imported) {
    const TopicItem& t = config_.imports[op.item];
    if (prefixOf(op.writer_guid) == own_prefix_) return;  // our own export of the same topic
    // Checked before the hub sees it: a sample that does not read as its type is dropped.
    if (t.encoding == Encoding::cdr) {
      if (auto v = ros2::validate(registry_, t.type, op.bytes); !v) {
        emit({BridgeEvent::Kind::malformed, ItemList::imports, op.item, {}, 0, v.error().message});
        return;
      }
      emit({BridgeEvent::Kind::sample, ItemList::imports, op.item, std::move(op.bytes), 0,
            std::move(op.writer_guid)});
      return;
    }
    if (t.encoding == Encoding::media) {
      auto frame = ros2::imageToFrame(t.type, op.bytes, frames_[op.item], nowNs());
      if (!frame) {
        emit({BridgeEvent::Kind::malformed,
              ItemList::imports,
              op.item,
              {},
              0,
              frame.error().message});
        return;
      }
      frames_[op.item] += 1;
      emit({BridgeEvent::Kind::sample, ItemList::imports, op.item, std::move(*frame), 0,
            std::move(op.writer_guid)});
      return;
    }
    auto v = ros2::cdrToJson(registry_, t.type, op.bytes);
    if (!v) {
      emit({BridgeEvent::Kind::malformed, ItemList::imports, op.item, {}, 0, v.error().message});
      return;
    }
    emit({BridgeEvent::Kind::sample, ItemList::imports, op.item, support::writeJson(*v), 0,
          std::move(op.writer_guid)});
    return;
  }
  if (op.kind == Op::Kind::add_export || op.kind == Op::Kind::remove_export) {
    changeExports(op);
    return;
  }
  if (op.item >= writers_.size() || writers_[op.item] == 0) return;  // removed, or never made
  const TopicItem& t = exports_[op.item];
  auto sample = t.encoding == Encoding::json ? fromJson(t.type, op.bytes)
                : t.encoding == Encoding::media
                    ? ros2::frameToImage(t.type, op.bytes, t.frame_id, nowNs())
                    : checked(t.type, op.bytes);
  if (!sample) {
    emit({BridgeEvent::Kind::malformed, ItemList::exports, op.item, {}, 0, sample.error().message});
    return;
  }
  if (auto r = participant_->write(writers_[op.item], *sample); !r) {
    emit({BridgeEvent::Kind::dropped, ItemList::exports, op.item, {}, 0, r.error().message});
  }
}

void DdsWorker::changeReading(Op& op) {
  const TopicItem& t = config_.imports[op.item];
  if (t.qos.durability == Durability::transient_local) return;  // read from the start, always
  EndpointId& reader = readers_[op.item];
  if (op.kind == Op::Kind::start_reading) {
    if (reader != 0) return;
    auto id = createImportReader(op.item);
    if (!id) {
      emit({BridgeEvent::Kind::malformed, ItemList::imports, op.item, {}, 0, id.error().message});
      return;
    }
    reader = *id;
  } else {
    if (reader == 0) return;
    (void)participant_->deleteEndpoint(reader);  // no callback of it after this
    reader = 0;
    emit({BridgeEvent::Kind::matched, ItemList::imports, op.item, {}, 0});
  }
  if (auto r = publishGraph(); !r) {
    emit({BridgeEvent::Kind::dropped, ItemList::imports, op.item, {}, 0, r.error().message});
  }
}

void DdsWorker::changeExports(Op& op) {
  if (op.kind == Op::Kind::add_export) {
    // Items are numbered in the order the loop added them, and ops run in that order.
    exports_.push_back(std::move(op.topic));
    auto id = createExportWriter(exports_.size() - 1);
    writers_.push_back(id ? *id : 0);
    if (!id) {
      emit({BridgeEvent::Kind::malformed, ItemList::exports, op.item, {}, 0, id.error().message});
      return;
    }
  } else {
    if (op.item >= writers_.size() || writers_[op.item] == 0) return;
    (void)participant_->deleteEndpoint(writers_[op.item]);
    writers_[op.item] = 0;
  }
  if (auto r = publishGraph(); !r) {
    emit({BridgeEvent::Kind::dropped, ItemList::exports, op.item, {}, 0, r.error().message});
  }
}

Result<std::string> DdsWorker::fromJson(const std::string& type, const std::string& json) const {
  auto value = support::parseJson(json);
  if (!value) return makeError(Errc::invalid_argument, "not JSON: " + value.error().message);
  return ros2::jsonToCdr(registry_, type, *value);
}

Result<std::string> DdsWorker::checked(const std::string& type, std::string& cdr) const {
  if (auto v = ros2::validate(registry_, type, cdr); !v) return v.error();
  return std::move(cdr);
}

void DdsWorker::handleService(Op& op) {
  if (op.list == ItemList::service_exports) {
    const ServiceItem& t = config_.service_exports[op.item];
    const ServiceEndpoints& e = service_exports_[op.item];
    if (op.kind == Op::Kind::request) {
      // The reply goes to the client's reply reader when it named one (rmw_fastrtps, Humble
      // on), else to its request writer; and says which request it answers by its number.
      auto value = ros2::cdrToJson(registry_, t.type + "_Request", op.bytes);
      if (!value) {
        emit({BridgeEvent::Kind::malformed,
              ItemList::service_exports,
              op.item,
              {},
              0,
              value.error().message});
        return;
      }
      SampleIdentity to{op.related.writer != Gid{} ? op.related.writer : op.identity.writer,
                        op.identity.sequence};
      BridgeEvent ev{BridgeEvent::Kind::request, ItemList::service_exports, op.item,
                     support::writeJson(*value)};
      ev.identity = to;
      emit(std::move(ev));
      return;
    }
    // The hub's answer: a Response, or for a failure the Response's success and message fields
    // where it has them (Trigger, SetBool); else no reply (ROS 2 services carry no error).
    const std::string response_type = t.type + "_Response";
    Result<std::string> sample = op.ok ? fromJson(response_type, op.bytes)
                                       : Result<std::string>(makeError(Errc::io_error, op.bytes));
    if (!sample) {
      const std::string why = sample.error().message;
      const ros2::MessageDefinition* def = registry_.find(response_type);
      const bool has_status =
          def != nullptr &&
          std::any_of(def->fields.begin(), def->fields.end(),
                      [](const ros2::Field& f) { return f.name == "success"; }) &&
          std::any_of(def->fields.begin(), def->fields.end(),
                      [](const ros2::Field& f) { return f.name == "message"; });
      emit({BridgeEvent::Kind::malformed,
            ItemList::service_exports,
            op.item,
            {},
            0,
            (op.ok ? "the answer: " : "the hub service failed: ") + why});
      if (!has_status) return;
      Json::Value failure(Json::objectValue);
      failure["success"] = false;
      failure["message"] = why;
      sample = ros2::jsonToCdr(registry_, response_type, failure);
      if (!sample) return;
    }
    if (auto r = participant_->writeRelated(e.replies, *sample, op.identity); !r) {
      emit({BridgeEvent::Kind::dropped,
            ItemList::service_exports,
            op.item,
            {},
            0,
            r.error().message});
    }
    return;
  }
  const ServiceItem& t = config_.service_imports[op.item];
  const ServiceEndpoints& e = service_imports_[op.item];
  if (op.kind == Op::Kind::request) {
    auto sample = fromJson(t.type + "_Request", op.bytes);
    if (!sample) {
      emit({BridgeEvent::Kind::failed,
            ItemList::service_imports,
            op.item,
            {},
            0,
            sample.error().message,
            {},
            op.tag});
      return;
    }
    // The server answers to our reply reader, named in the request (rmw_fastrtps's client).
    auto sent = participant_->writeRelated(e.requests, *sample,
                                           SampleIdentity{participant_->gid(e.replies), 0});
    if (!sent) {
      emit({BridgeEvent::Kind::failed,
            ItemList::service_imports,
            op.item,
            {},
            0,
            sent.error().message,
            {},
            op.tag});
      return;
    }
    BridgeEvent ev{BridgeEvent::Kind::sent, ItemList::service_imports, op.item};
    ev.identity = *sent;
    ev.tag = op.tag;
    emit(std::move(ev));
    return;
  }
  // A reply: ours when it names our reply reader or our request writer (older servers).
  if (op.related.writer != participant_->gid(e.replies) &&
      op.related.writer != participant_->gid(e.requests)) {
    return;  // another client's
  }
  auto value = ros2::cdrToJson(registry_, t.type + "_Response", op.bytes);
  BridgeEvent ev{BridgeEvent::Kind::reply, ItemList::service_imports, op.item};
  ev.identity = op.related;
  if (value) {
    ev.payload = support::writeJson(*value);
  } else {
    Json::Value error(Json::objectValue);
    error["error"] = "malformed";
    error["message"] = value.error().message;
    ev.payload = support::writeJson(error);
  }
  emit(std::move(ev));
}

}  // namespace skr::ros2_bridge
