// SPDX-License-Identifier: Apache-2.0
#include "dds_participant.h"

#include "raw_type.h"
#include "ros_names.h"

#include <skrobot/ros2/definitions.h>
#include <skrobot/support/pin_library.hpp>

#include <fastdds/rtps/common/InstanceHandle.h>
#include <fastdds/rtps/common/WriteParams.h>
#include <fastdds/rtps/transport/TCPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/TCPv6TransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv6TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/attributes/LibrarySettingsAttributes.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastrtps/xmlparser/XMLProfileManager.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/log/Log.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>

#include <arpa/inet.h>
#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <sstream>

namespace skr::ros2_bridge {

namespace dds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
using eprosima::fastrtps::rtps::IPLocator;

namespace {

Error notConfined(const std::string& what) {
  return makeError(Errc::permission_denied, "ROS2-NOT-CONFINED not confined: " + what);
}

std::string join(const std::vector<std::string>& items) {
  std::string out = "[";
  for (std::size_t i = 0; i < items.size(); ++i) out += (i ? ", " : "") + items[i];
  return out + "]";
}

std::optional<in_addr> parseIpv4(const std::string& text) {
  in_addr addr{};
  if (inet_pton(AF_INET, text.c_str(), &addr) != 1) return std::nullopt;
  return addr;
}

bool isLoopback(const in_addr& addr) {
  return (ntohl(addr.s_addr) >> 24) == 127;
}
bool isMulticast(const in_addr& addr) {
  return (ntohl(addr.s_addr) >> 28) == 0xE;
}

std::string locatorText(const rtps::Locator_t& locator) {
  std::string address;
  switch (locator.kind) {
    case LOCATOR_KIND_UDPv4:
    case LOCATOR_KIND_TCPv4:
      address = IPLocator::toIPv4string(locator);
      break;
    case LOCATOR_KIND_UDPv6:
    case LOCATOR_KIND_TCPv6:
      address = "[" + IPLocator::toIPv6string(locator) + "]";
      break;
    case LOCATOR_KIND_SHM:
      address = "shm";
      break;
    default:
      address = "kind" + std::to_string(locator.kind);
  }
  return locator.port == 0 ? address : address + ":" + std::to_string(locator.port);
}

// The address part of locatorText's "address:port".
std::string addressOf(const std::string& locator) {
  const auto colon = locator.rfind(':');
  return colon == std::string::npos || locator.front() == '[' ? locator : locator.substr(0, colon);
}

template <typename List>
void addLocators(const List& list, std::vector<std::string>& unicast,
                 std::vector<std::string>& multicast) {
  for (const auto& locator : list) {
    (IPLocator::isMulticast(locator) ? multicast : unicast).push_back(locatorText(locator));
  }
}

std::string guidText(const rtps::GUID_t& guid) {
  std::ostringstream out;
  out << guid;
  return out.str();
}

Gid gidOf(const rtps::GUID_t& guid) {
  Gid out{};
  std::memcpy(out.data(), guid.guidPrefix.value, 12);
  std::memcpy(out.data() + 12, guid.entityId.value, 4);
  return out;
}

rtps::GUID_t guidOf(const Gid& gid) {
  rtps::GUID_t guid;
  std::memcpy(guid.guidPrefix.value, gid.data(), 12);
  std::memcpy(guid.entityId.value, gid.data() + 12, 4);
  return guid;
}

SampleIdentity identityOf(const rtps::SampleIdentity& id) {
  if (id == rtps::SampleIdentity::unknown()) return {};
  return {gidOf(id.writer_guid()), static_cast<std::int64_t>(id.sequence_number().to64long())};
}

std::int64_t nanoseconds(const rtps::Time_t& t) {
  return static_cast<std::int64_t>(t.seconds()) * 1000000000 + t.nanosec();
}

std::string policyName(dds::QosPolicyId_t id) {
  switch (id) {
    case dds::DURABILITY_QOS_POLICY_ID:
      return "durability";
    case dds::PRESENTATION_QOS_POLICY_ID:
      return "presentation";
    case dds::DEADLINE_QOS_POLICY_ID:
      return "deadline";
    case dds::LATENCYBUDGET_QOS_POLICY_ID:
      return "latency_budget";
    case dds::OWNERSHIP_QOS_POLICY_ID:
      return "ownership";
    case dds::LIVELINESS_QOS_POLICY_ID:
      return "liveliness";
    case dds::RELIABILITY_QOS_POLICY_ID:
      return "reliability";
    case dds::DESTINATIONORDER_QOS_POLICY_ID:
      return "destination_order";
    case dds::DATAREPRESENTATION_QOS_POLICY_ID:
      return "data_representation";
    case dds::DISABLEPOSITIVEACKS_QOS_POLICY_ID:
      return "disable_positive_acks";
    default:
      return "policy " + std::to_string(static_cast<int>(id));
  }
}

std::string discoveryName(rtps::DiscoveryProtocol_t protocol) {
  switch (protocol) {
    case rtps::DiscoveryProtocol_t::NONE:
      return "NONE";
    case rtps::DiscoveryProtocol_t::SIMPLE:
      return "SIMPLE";
    case rtps::DiscoveryProtocol_t::EXTERNAL:
      return "EXTERNAL";
    case rtps::DiscoveryProtocol_t::CLIENT:
      return "CLIENT";
    case rtps::DiscoveryProtocol_t::SERVER:
      return "SERVER";
    case rtps::DiscoveryProtocol_t::BACKUP:
      return "BACKUP";
    case rtps::DiscoveryProtocol_t::SUPER_CLIENT:
      return "SUPER_CLIENT";
  }
  return "?";
}

rtps::Locator_t udpLocator(const std::string& address) {
  rtps::Locator_t locator;
  locator.kind = LOCATOR_KIND_UDPv4;
  locator.port = 0;
  IPLocator::setIPv4(locator, address);
  return locator;
}

Result<void> checkConfig(const ParticipantConfig& config) {
  if (config.domain > 232) {
    return makeError(Errc::invalid_argument,
                     "domain " + std::to_string(config.domain) + " is past 232 (RTPS ports)");
  }
  if (config.max_participants < 1 || config.max_participants > 120) {
    return makeError(Errc::invalid_argument, "max_participants must be 1..120");
  }
  if (config.interfaces.empty()) {
    return makeError(Errc::invalid_argument, "no interface: the UDPv4 whitelist would allow all");
  }
  const auto check = [&](const std::string& what, const std::string& text) -> Result<void> {
    auto addr = parseIpv4(text);
    if (!addr) return makeError(Errc::invalid_argument, what + " \"" + text + "\" is not IPv4");
    if (isMulticast(*addr)) return notConfined(what + " " + text + " is a multicast address");
    if (!config.allow_non_loopback && !isLoopback(*addr)) {
      return notConfined(what + " " + text + " is not loopback (allow_non_loopback is off)");
    }
    return {};
  };
  for (const auto& i : config.interfaces) {
    if (auto ok = check("interface", i); !ok) return ok;
  }
  for (const auto& p : config.peers) {
    if (auto ok = check("peer", p); !ok) return ok;
  }
  return {};
}

// Fast DDS stays mapped once loaded: the hub may dlclose the module while Fast DDS's exit-time
// destructors (its factory and log singletons) are still registered.
void pinFastDds() {
  for (const char* soname : {"libfastrtps.so.2.9", "libfastcdr.so.1"}) {
    (void)support::pinLoadedLibrary(soname);
  }
}

// The XML profiles, loaded once and explicitly: after it Fast DDS does not load them again, so
// the library settings set here stay.
void settleLibrary() {
  static std::once_flag once;
  std::call_once(once, [] {
    pinFastDds();
    dds::DomainParticipantFactory::get_instance()->load_profiles();
    auto settings = eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings();
    settings.intraprocess_delivery = eprosima::fastrtps::INTRAPROCESS_OFF;
    eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings(settings);
  });
}

std::mutex g_count_mutex;
int g_participants = 0;

// A listener's callbacks run only while its gate is open; closing waits for one in progress.
class Gate {
 public:
  template <typename F>
  void run(F&& f) {
    std::lock_guard lock(mutex_);
    if (open_) f();
  }
  void close() {
    std::lock_guard lock(mutex_);
    open_ = false;
  }

 private:
  std::mutex mutex_;
  bool open_ = true;
};

MatchStatus matchStatus(const dds::MatchedStatus& status, const rtps::InstanceHandle_t& last) {
  MatchStatus out;
  out.current = status.current_count;
  out.change = status.current_count_change;
  out.remote_guid = guidText(rtps::iHandle2GUID(last));
  return out;
}

class WriterListener final : public dds::DataWriterListener {
 public:
  explicit WriterListener(WriterCallbacks callbacks) : callbacks_(std::move(callbacks)) {}
  Gate gate;

  void on_publication_matched(dds::DataWriter*, const dds::PublicationMatchedStatus& s) override {
    gate.run([&] {
      if (callbacks_.on_matched) callbacks_.on_matched(matchStatus(s, s.last_subscription_handle));
    });
  }
  void on_offered_incompatible_qos(dds::DataWriter*,
                                   const dds::OfferedIncompatibleQosStatus& s) override {
    gate.run([&] {
      if (callbacks_.on_incompatible_qos) {
        callbacks_.on_incompatible_qos({policyName(s.last_policy_id), s.total_count});
      }
    });
  }

 private:
  WriterCallbacks callbacks_;
};

class ReaderListener final : public dds::DataReaderListener {
 public:
  explicit ReaderListener(ReaderCallbacks callbacks) : callbacks_(std::move(callbacks)) {}
  Gate gate;

  void on_data_available(dds::DataReader* reader) override {
    gate.run([&] {
      RawCdrSample holder;
      dds::SampleInfo info;
      while (reader->take_next_sample(&holder, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        Sample sample;
        sample.bytes = std::move(holder.owned);
        holder.owned = std::string();
        sample.writer_guid = guidText(info.sample_identity.writer_guid());
        sample.source_timestamp_ns = nanoseconds(info.source_timestamp);
        sample.reception_timestamp_ns = nanoseconds(info.reception_timestamp);
        sample.sequence = info.sample_identity.sequence_number().to64long();
        sample.identity = identityOf(info.sample_identity);
        sample.related = identityOf(info.related_sample_identity);
        if (callbacks_.on_sample) callbacks_.on_sample(std::move(sample));
      }
    });
  }
  void on_subscription_matched(dds::DataReader*, const dds::SubscriptionMatchedStatus& s) override {
    gate.run([&] {
      if (callbacks_.on_matched) callbacks_.on_matched(matchStatus(s, s.last_publication_handle));
    });
  }
  void on_requested_incompatible_qos(dds::DataReader*,
                                     const dds::RequestedIncompatibleQosStatus& s) override {
    gate.run([&] {
      if (callbacks_.on_incompatible_qos) {
        callbacks_.on_incompatible_qos({policyName(s.last_policy_id), s.total_count});
      }
    });
  }

 private:
  ReaderCallbacks callbacks_;
};

class ParticipantListener final : public dds::DomainParticipantListener {
 public:
  explicit ParticipantListener(std::function<void(const RemoteParticipant&)> callback)
      : callback_(std::move(callback)) {}
  Gate gate;

  void on_participant_discovery(dds::DomainParticipant*,
                                rtps::ParticipantDiscoveryInfo&& info) override {
    gate.run([&] {
      if (!callback_) return;
      RemoteParticipant remote;
      using S = rtps::ParticipantDiscoveryInfo::DISCOVERY_STATUS;
      switch (info.status) {
        case S::DISCOVERED_PARTICIPANT:
          remote.change = RemoteParticipant::Change::discovered;
          break;
        case S::CHANGED_QOS_PARTICIPANT:
          remote.change = RemoteParticipant::Change::changed;
          break;
        case S::REMOVED_PARTICIPANT:
          remote.change = RemoteParticipant::Change::removed;
          break;
        case S::DROPPED_PARTICIPANT:
          remote.change = RemoteParticipant::Change::dropped;
          break;
      }
      remote.guid = guidText(info.info.m_guid);
      remote.name = info.info.m_participantName.to_string();
      addLocators(info.info.metatraffic_locators.unicast, remote.unicast_locators,
                  remote.multicast_locators);
      addLocators(info.info.metatraffic_locators.multicast, remote.unicast_locators,
                  remote.multicast_locators);
      addLocators(info.info.default_locators.unicast, remote.unicast_locators,
                  remote.multicast_locators);
      addLocators(info.info.default_locators.multicast, remote.unicast_locators,
                  remote.multicast_locators);
      callback_(remote);
    });
  }

 private:
  std::function<void(const RemoteParticipant&)> callback_;
};

ParticipantFacts readBack(const dds::DomainParticipantQos& qos) {
  ParticipantFacts facts;
  const auto& builtin = qos.wire_protocol().builtin;
  facts.discovery = discoveryName(builtin.discovery_config.discoveryProtocol);
  facts.builtin_transports = qos.transport().use_builtin_transports;
  for (const auto& descriptor : qos.transport().user_transports) {
    ParticipantFacts::Transport t;
    if (auto udp4 = std::dynamic_pointer_cast<eprosima::fastdds::rtps::UDPv4TransportDescriptor>(
            descriptor)) {
      t.kind = "UDPv4";
      t.whitelist = udp4->interfaceWhiteList;
    } else if (std::dynamic_pointer_cast<eprosima::fastdds::rtps::UDPv6TransportDescriptor>(
                   descriptor)) {
      t.kind = "UDPv6";
    } else if (std::dynamic_pointer_cast<eprosima::fastdds::rtps::SharedMemTransportDescriptor>(
                   descriptor)) {
      t.kind = "SHM";
    } else if (std::dynamic_pointer_cast<eprosima::fastdds::rtps::TCPv4TransportDescriptor>(
                   descriptor)) {
      t.kind = "TCPv4";
    } else if (std::dynamic_pointer_cast<eprosima::fastdds::rtps::TCPv6TransportDescriptor>(
                   descriptor)) {
      t.kind = "TCPv6";
    } else {
      t.kind = "other";
    }
    facts.transports.push_back(std::move(t));
  }
  addLocators(builtin.metatrafficUnicastLocatorList, facts.unicast_locators,
              facts.multicast_locators);
  addLocators(builtin.metatrafficMulticastLocatorList, facts.unicast_locators,
              facts.multicast_locators);
  addLocators(qos.wire_protocol().default_unicast_locator_list, facts.unicast_locators,
              facts.multicast_locators);
  addLocators(qos.wire_protocol().default_multicast_locator_list, facts.unicast_locators,
              facts.multicast_locators);
  addLocators(builtin.initialPeersList, facts.initial_peers, facts.multicast_locators);
  facts.intraprocess_off =
      eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings().intraprocess_delivery ==
      eprosima::fastrtps::INTRAPROCESS_OFF;
  return facts;
}

}  // namespace

std::optional<Qos> qosProfile(std::string_view name) {
  Qos qos;  // default: reliable, volatile, keep_last 10
  if (name == "default" || name == "services" || name == "system") return qos;
  if (name == "sensor_data") {
    qos.reliability = Reliability::best_effort;
    qos.depth = 5;
    return qos;
  }
  return std::nullopt;
}

std::string describe(const Qos& qos) {
  std::string out = qos.reliability == Reliability::reliable ? "reliable" : "best_effort";
  out += qos.durability == Durability::volatile_ ? ", volatile" : ", transient_local";
  out += qos.history == History::keep_last ? ", keep_last " + std::to_string(qos.depth)
                                           : std::string(", keep_all");
  if (qos.deadline_ms > 0) out += ", deadline " + std::to_string(qos.deadline_ms) + " ms";
  return out;
}

Result<void> checkEnvironment() {
  for (const char* name : {"ROS_DISCOVERY_SERVER", "FASTDDS_ENVIRONMENT_FILE"}) {
    const char* value = std::getenv(name);
    if (value && *value) {
      return notConfined(std::string(name) + "=" + value +
                         " is set: Fast DDS would make this participant a discovery-server "
                         "client (unset it for the bridge)");
    }
  }
  return {};
}

Result<void> checkConfined(const ParticipantFacts& facts, const ParticipantConfig& config) {
  if (facts.discovery != "SIMPLE") return notConfined("discovery " + facts.discovery);
  if (facts.builtin_transports) return notConfined("builtin transports on");
  if (facts.transports.size() != 1 || facts.transports.front().kind != "UDPv4") {
    std::vector<std::string> kinds;
    for (const auto& t : facts.transports) kinds.push_back(t.kind);
    return notConfined("transports " + join(kinds) + ", not one UDPv4");
  }
  auto whitelist = facts.transports.front().whitelist;
  auto wanted = config.interfaces;
  std::sort(whitelist.begin(), whitelist.end());
  std::sort(wanted.begin(), wanted.end());
  if (whitelist != wanted) {
    return notConfined("UDPv4 whitelist " + join(facts.transports.front().whitelist) +
                       ", configured " + join(config.interfaces));
  }
  if (!facts.multicast_locators.empty()) {
    return notConfined("multicast locator " + facts.multicast_locators.front());
  }
  for (const auto& locator : facts.unicast_locators) {
    const auto address = addressOf(locator);
    if (std::find(config.interfaces.begin(), config.interfaces.end(), address) ==
        config.interfaces.end()) {
      return notConfined("unicast locator " + locator + " is on no configured interface");
    }
  }
  for (const auto& peer : facts.initial_peers) {
    const auto address = addressOf(peer);
    if (std::find(config.peers.begin(), config.peers.end(), address) == config.peers.end()) {
      return notConfined("initial peer " + peer + " is not a configured peer");
    }
  }
  if (!facts.intraprocess_off) return notConfined("intra-process delivery on");
  return {};
}

struct DdsParticipant::Impl {
  ParticipantConfig config;
  dds::DomainParticipant* participant = nullptr;
  dds::Publisher* publisher = nullptr;
  dds::Subscriber* subscriber = nullptr;
  std::unique_ptr<ParticipantListener> participant_listener;
  ParticipantFacts facts;

  struct TopicEntry {
    dds::Topic* topic = nullptr;
    int users = 0;
  };
  std::map<std::string, TopicEntry, std::less<>> topics;       // by DDS topic name
  std::map<std::string, dds::TypeSupport, std::less<>> types;  // by DDS type name

  struct Endpoint {
    std::string topic;
    dds::DataWriter* writer = nullptr;
    dds::DataReader* reader = nullptr;
    Gate* gate = nullptr;  // its listener's
  };
  std::map<EndpointId, Endpoint> endpoints;
  EndpointId next_id = 1;
  // Listeners of deleted endpoints: kept until the participant is gone, as a Fast DDS thread
  // may still be entering one when its endpoint is deleted (the gate keeps it from calling out).
  std::vector<std::unique_ptr<dds::DataWriterListener>> writer_listeners;
  std::vector<std::unique_ptr<dds::DataReaderListener>> reader_listeners;

  Result<dds::Topic*> topic(const std::string& name, const std::string& type_name) {
    if (auto it = topics.find(name); it != topics.end()) {
      if (it->second.topic->get_type_name() != type_name) {
        return makeError(Errc::invalid_argument, "topic " + name + " already has type " +
                                                     it->second.topic->get_type_name());
      }
      ++it->second.users;
      return it->second.topic;
    }
    if (types.find(type_name) == types.end()) {
      dds::TypeSupport support(new RawCdrType(type_name));
      if (support.register_type(participant) != ReturnCode_t::RETCODE_OK) {
        return makeError(Errc::internal, "cannot register type " + type_name);
      }
      types.emplace(type_name, support);
    }
    dds::Topic* t = participant->create_topic(name, type_name, dds::TopicQos());
    if (!t) return makeError(Errc::internal, "cannot create topic " + name);
    topics.emplace(name, TopicEntry{t, 1});
    return t;
  }

  void releaseTopic(const std::string& name) {
    auto it = topics.find(name);
    if (it == topics.end() || --it->second.users > 0) return;
    participant->delete_topic(it->second.topic);
    topics.erase(it);
  }
};

namespace {

template <typename EndpointQos>
void applyQos(EndpointQos& q, const Qos& qos) {
  q.reliability().kind = qos.reliability == Reliability::reliable
                             ? dds::RELIABLE_RELIABILITY_QOS
                             : dds::BEST_EFFORT_RELIABILITY_QOS;
  q.durability().kind = qos.durability == Durability::volatile_
                            ? dds::VOLATILE_DURABILITY_QOS
                            : dds::TRANSIENT_LOCAL_DURABILITY_QOS;
  q.history().kind =
      qos.history == History::keep_last ? dds::KEEP_LAST_HISTORY_QOS : dds::KEEP_ALL_HISTORY_QOS;
  q.history().depth = qos.depth;
  if (qos.history == History::keep_last) {
    // Keyless topics: one instance, whose history is the depth.
    q.resource_limits().max_samples_per_instance = qos.depth;
    q.resource_limits().max_samples = qos.depth;
    q.resource_limits().max_instances = 1;
  }
  if (qos.deadline_ms > 0) {
    q.deadline().period = eprosima::fastrtps::Duration_t(
        static_cast<std::int32_t>(qos.deadline_ms / 1000),
        static_cast<std::uint32_t>((qos.deadline_ms % 1000) * 1000000));
  } else {
    q.deadline().period = eprosima::fastrtps::c_TimeInfinite;
  }
  q.data_sharing().off();
  q.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
}

Result<void> checkQos(const Qos& qos) {
  if (qos.history == History::keep_last && (qos.depth < 1 || qos.depth > 100000)) {
    return makeError(Errc::invalid_argument, "QoS depth must be 1..100000");
  }
  if (qos.deadline_ms < 0) return makeError(Errc::invalid_argument, "QoS deadline_ms below 0");
  return {};
}

}  // namespace

DdsParticipant::DdsParticipant(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Result<std::unique_ptr<DdsParticipant>> DdsParticipant::create(
    const ParticipantConfig& config, std::function<void(const RemoteParticipant&)> on_participant) {
  if (auto ok = checkConfig(config); !ok) return ok.error();
  if (auto ok = checkEnvironment(); !ok) return ok.error();
  settleLibrary();

  auto descriptor = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  descriptor->interfaceWhiteList = config.interfaces;
  descriptor->maxInitialPeersRange = config.max_participants;
  if (config.socket_buffer_bytes > 0) {
    descriptor->sendBufferSize = config.socket_buffer_bytes;
    descriptor->receiveBufferSize = config.socket_buffer_bytes;
  }

  // Not the factory's default QoS (an XML profile may have changed it): a fresh one.
  dds::DomainParticipantQos qos;
  qos.name(config.enclave);
  const std::string user_data = "enclave=" + config.enclave + ";";
  qos.user_data().data_vec(std::vector<rtps::octet>(user_data.begin(), user_data.end()));
  qos.transport().use_builtin_transports = false;
  qos.transport().user_transports = {descriptor};
  if (config.socket_buffer_bytes > 0) {
    qos.transport().send_socket_buffer_size = config.socket_buffer_bytes;
    qos.transport().listen_socket_buffer_size = config.socket_buffer_bytes;
  }
  auto& builtin = qos.wire_protocol().builtin;
  builtin.discovery_config.discoveryProtocol = rtps::DiscoveryProtocol_t::SIMPLE;
  builtin.discovery_config.use_SIMPLE_EndpointDiscoveryProtocol = true;
  builtin.use_WriterLivelinessProtocol = true;
  builtin.avoid_builtin_multicast = true;
  builtin.metatrafficMulticastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(udpLocator(config.interfaces.front()));
  builtin.initialPeersList.clear();
  for (const auto& peer : config.peers) builtin.initialPeersList.push_back(udpLocator(peer));
  qos.wire_protocol().default_multicast_locator_list.clear();
  qos.wire_protocol().default_unicast_locator_list.clear();
  qos.wire_protocol().default_unicast_locator_list.push_back(udpLocator(config.interfaces.front()));

  auto impl = std::make_unique<Impl>();
  impl->config = config;
  impl->participant_listener = std::make_unique<ParticipantListener>(std::move(on_participant));
  auto* factory = dds::DomainParticipantFactory::get_instance();
  impl->participant = factory->create_participant(
      config.domain, qos, impl->participant_listener.get(), dds::StatusMask::none());
  {
    std::lock_guard lock(g_count_mutex);
    ++g_participants;  // the destructor counts it down, created or not
  }
  auto self = std::unique_ptr<DdsParticipant>(new DdsParticipant(std::move(impl)));
  Impl& p = *self->impl_;
  if (!p.participant) {
    return makeError(Errc::io_error, "Fast DDS could not create the participant (domain " +
                                         std::to_string(config.domain) + ")");
  }
  p.facts = readBack(p.participant->get_qos());
  if (auto ok = checkConfined(p.facts, config); !ok) return ok.error();
  p.publisher = p.participant->create_publisher(dds::PublisherQos());
  p.subscriber = p.participant->create_subscriber(dds::SubscriberQos());
  if (!p.publisher || !p.subscriber) {
    return makeError(Errc::internal, "cannot create the publisher and subscriber");
  }
  return self;
}

DdsParticipant::~DdsParticipant() {
  if (impl_->participant) {
    impl_->participant_listener->gate.close();
    for (auto& [id, endpoint] : impl_->endpoints) endpoint.gate->close();
    impl_->participant->delete_contained_entities();
    dds::DomainParticipantFactory::get_instance()->delete_participant(impl_->participant);
    impl_->participant = nullptr;
  }
  std::lock_guard lock(g_count_mutex);
  if (--g_participants == 0) {
    // Fast DDS's log thread, started by its first log line, is process-wide.
    dds::Log::KillThread();
  }
}

Result<EndpointId> DdsParticipant::createWriter(std::string_view ros_topic,
                                                std::string_view ros_type, const Qos& qos,
                                                WriterCallbacks callbacks) {
  auto name = ddsTopicName(ros_topic);
  if (!name) return name.error();
  auto full = ros2::fullName(ros_type);
  if (!full) return makeError(Errc::invalid_argument, "type \"" + std::string(ros_type) + "\"");
  return createDdsWriter(*name, ros2::ddsTypeName(*full), qos, std::move(callbacks));
}

Result<EndpointId> DdsParticipant::createDdsWriter(const std::string& name,
                                                   const std::string& type_name, const Qos& qos,
                                                   WriterCallbacks callbacks) {
  if (auto ok = checkQos(qos); !ok) return ok.error();
  Impl& p = *impl_;
  auto topic = p.topic(name, type_name);
  if (!topic) return topic.error();

  dds::DataWriterQos wq;
  applyQos(wq, qos);
  wq.publish_mode().kind = dds::SYNCHRONOUS_PUBLISH_MODE;
  auto listener = std::make_unique<WriterListener>(std::move(callbacks));
  dds::DataWriter* writer =
      p.publisher->create_datawriter(*topic, wq, listener.get(), dds::StatusMask::all());
  if (!writer) {
    p.releaseTopic(name);
    return makeError(Errc::invalid_argument,
                     "Fast DDS refused a writer on " + name + " (" + describe(qos) + ")");
  }
  if (writer->get_qos().data_sharing().kind() != dds::OFF) {
    p.publisher->delete_datawriter(writer);
    p.releaseTopic(name);
    return notConfined("data sharing on the writer of " + name);
  }
  Gate* gate = &listener->gate;
  p.writer_listeners.push_back(std::move(listener));
  const EndpointId id = p.next_id++;
  p.endpoints.emplace(id, Impl::Endpoint{name, writer, nullptr, gate});
  return id;
}

Result<EndpointId> DdsParticipant::createReader(std::string_view ros_topic,
                                                std::string_view ros_type, const Qos& qos,
                                                ReaderCallbacks callbacks) {
  auto name = ddsTopicName(ros_topic);
  if (!name) return name.error();
  auto full = ros2::fullName(ros_type);
  if (!full) return makeError(Errc::invalid_argument, "type \"" + std::string(ros_type) + "\"");
  return createDdsReader(*name, ros2::ddsTypeName(*full), qos, std::move(callbacks));
}

Result<EndpointId> DdsParticipant::createDdsReader(const std::string& name,
                                                   const std::string& type_name, const Qos& qos,
                                                   ReaderCallbacks callbacks) {
  if (auto ok = checkQos(qos); !ok) return ok.error();
  Impl& p = *impl_;
  auto topic = p.topic(name, type_name);
  if (!topic) return topic.error();

  dds::DataReaderQos rq;
  applyQos(rq, qos);
  auto listener = std::make_unique<ReaderListener>(std::move(callbacks));
  dds::DataReader* reader =
      p.subscriber->create_datareader(*topic, rq, listener.get(), dds::StatusMask::all());
  if (!reader) {
    p.releaseTopic(name);
    return makeError(Errc::invalid_argument,
                     "Fast DDS refused a reader on " + name + " (" + describe(qos) + ")");
  }
  if (reader->get_qos().data_sharing().kind() != dds::OFF) {
    p.subscriber->delete_datareader(reader);
    p.releaseTopic(name);
    return notConfined("data sharing on the reader of " + name);
  }
  Gate* gate = &listener->gate;
  p.reader_listeners.push_back(std::move(listener));
  const EndpointId id = p.next_id++;
  p.endpoints.emplace(id, Impl::Endpoint{name, nullptr, reader, gate});
  return id;
}

Gid DdsParticipant::gid(EndpointId id) const {
  auto it = impl_->endpoints.find(id);
  if (it == impl_->endpoints.end()) return {};
  return gidOf(it->second.writer ? it->second.writer->guid() : it->second.reader->guid());
}

Gid DdsParticipant::participantGid() const {
  return gidOf(impl_->participant->guid());
}

Result<SampleIdentity> DdsParticipant::writeRelated(EndpointId writer, std::string_view cdr,
                                                    const SampleIdentity& related) {
  auto it = impl_->endpoints.find(writer);
  if (it == impl_->endpoints.end() || !it->second.writer) {
    return makeError(Errc::not_found, "no writer " + std::to_string(writer));
  }
  if (cdr.size() < 4) {
    return makeError(Errc::invalid_argument, "a CDR sample needs its 4-byte header");
  }
  RawCdrSample sample;
  sample.view = reinterpret_cast<const std::uint8_t*>(cdr.data());
  sample.view_size = cdr.size();
  rtps::WriteParams params;
  if (related.valid() || related.writer != Gid{}) {
    rtps::SampleIdentity r;
    r.writer_guid(guidOf(related.writer));
    r.sequence_number(rtps::SequenceNumber_t(static_cast<std::int32_t>(related.sequence >> 32),
                                             static_cast<std::uint32_t>(related.sequence)));
    params.related_sample_identity(r);
  }
  if (!it->second.writer->write(&sample, params)) {
    return makeError(Errc::io_error, "write on " + it->second.topic + " failed");
  }
  return identityOf(params.sample_identity());
}

Result<void> DdsParticipant::write(EndpointId writer, std::string_view cdr) {
  auto it = impl_->endpoints.find(writer);
  if (it == impl_->endpoints.end() || !it->second.writer) {
    return makeError(Errc::not_found, "no writer " + std::to_string(writer));
  }
  if (cdr.size() < 4) {
    return makeError(Errc::invalid_argument, "a CDR sample needs its 4-byte header");
  }
  RawCdrSample sample;
  sample.view = reinterpret_cast<const std::uint8_t*>(cdr.data());
  sample.view_size = cdr.size();
  const ReturnCode_t rc = it->second.writer->write(&sample, rtps::c_InstanceHandle_Unknown);
  if (rc == ReturnCode_t::RETCODE_OK) return {};
  if (rc == ReturnCode_t::RETCODE_TIMEOUT) {
    return makeError(Errc::timeout, "write on " + it->second.topic + ": history full");
  }
  return makeError(Errc::io_error, "write on " + it->second.topic + " failed (Fast DDS code " +
                                       std::to_string(rc()) + ")");
}

Result<void> DdsParticipant::waitForAcknowledgments(EndpointId writer, std::int64_t timeout_ms) {
  auto it = impl_->endpoints.find(writer);
  if (it == impl_->endpoints.end() || !it->second.writer) {
    return makeError(Errc::not_found, "no writer " + std::to_string(writer));
  }
  const eprosima::fastrtps::Duration_t timeout(
      static_cast<std::int32_t>(timeout_ms / 1000),
      static_cast<std::uint32_t>((timeout_ms % 1000) * 1000000));
  if (it->second.writer->wait_for_acknowledgments(timeout) != ReturnCode_t::RETCODE_OK) {
    return makeError(Errc::timeout, "not acknowledged on " + it->second.topic);
  }
  return {};
}

Result<void> DdsParticipant::deleteEndpoint(EndpointId id) {
  Impl& p = *impl_;
  auto it = p.endpoints.find(id);
  if (it == p.endpoints.end())
    return makeError(Errc::not_found, "no endpoint " + std::to_string(id));
  it->second.gate->close();
  if (it->second.writer) p.publisher->delete_datawriter(it->second.writer);
  if (it->second.reader) p.subscriber->delete_datareader(it->second.reader);
  p.releaseTopic(it->second.topic);
  p.endpoints.erase(it);
  return {};
}

std::string DdsParticipant::guid() const {
  return impl_->participant ? guidText(impl_->participant->guid()) : std::string();
}

const ParticipantFacts& DdsParticipant::facts() const noexcept {
  return impl_->facts;
}

}  // namespace skr::ros2_bridge
