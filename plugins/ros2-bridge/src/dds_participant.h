// SPDX-License-Identifier: Apache-2.0
// The bridge's DDS side on Fast DDS: one participant confined to the configured interfaces, and
// writers and readers of raw CDR samples under ROS 2's names (rt/...) and QoS profiles. No Fast
// DDS type in this header, so that the module's other files compile quickly.
//
// Confinement (docs: DDS has no authentication; loopback unless configured). The participant's
// QoS is built in code only: the builtin transports off, one UDPv4 transport whose interface
// whitelist is `interfaces`, unicast metatraffic and user locators on the first interface with
// port 0 (Fast DDS picks the participant's well-known ports), `peers` as unicast initial peers
// (ports of participant ids 0..max_participants-1), no multicast locator, data sharing off on
// every endpoint and intra-process delivery off (a sample crosses the UDP transport even between
// two participants of one process). The Fast DDS XML profiles (FASTRTPS_DEFAULT_PROFILES_FILE,
// DEFAULT_FASTRTPS_PROFILES.xml in the working directory) are loaded once, explicitly, before
// the library settings are set, so that they cannot change them later; they do not reach this
// participant's QoS (not built from a profile). After creation the QoS is read back and the
// participant refused ("ROS2-NOT-CONFINED ...") unless it is what was asked (checkConfined).
// Fast DDS 2.9.1 turns a SIMPLE participant into a discovery-server client when
// ROS_DISCOVERY_SERVER is set (directly or through FASTDDS_ENVIRONMENT_FILE) without its QoS
// saying so: either variable set is refused before creation.
//
// Threads. create(), the destructor and every method: one owner thread (the bridge's DDS thread).
// write() of a reliable writer may block up to 100 ms when the history is full of unacknowledged
// samples. Callbacks run on Fast DDS's threads (receive, event): they must only hand over (copy,
// queue, wake the owner) and must not call this object. None runs after the delete call of its
// entity, or the destructor, has returned.
#pragma once

#include <skrobot/result.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace skr::ros2_bridge {

enum class Reliability : std::uint8_t { reliable, best_effort };
enum class Durability : std::uint8_t { volatile_, transient_local };
enum class History : std::uint8_t { keep_last, keep_all };

// An endpoint's QoS. Every field is set on the Fast DDS entity: Fast DDS's own defaults are not
// ROS 2's (its writers default to transient_local, its readers to best_effort).
struct Qos {
  Reliability reliability = Reliability::reliable;
  Durability durability = Durability::volatile_;
  History history = History::keep_last;
  std::int32_t depth = 10;
  std::int64_t deadline_ms = 0;  // 0: none (infinite)
};

// ROS 2's profiles (rmw/qos_profiles.h): "default" (reliable, volatile, keep_last 10),
// "sensor_data" (best_effort, volatile, keep_last 5), "services" (reliable, volatile, keep_last
// 10), "system" (the same as default here: ROS 2 leaves it to the middleware, whose ROS default
// is this). nullopt for another name.
[[nodiscard]] std::optional<Qos> qosProfile(std::string_view name);
[[nodiscard]] std::string describe(const Qos& qos);

struct ParticipantConfig {
  std::uint32_t domain = 0;  // 0..232
  // The UDPv4 whitelist, as addresses ("127.0.0.1"). The first also carries the participant's
  // unicast locators.
  std::vector<std::string> interfaces{"127.0.0.1"};
  std::vector<std::string> peers{"127.0.0.1"};  // unicast initial peers (addresses)
  std::uint32_t max_participants = 20;          // well-known ports probed per peer
  // Whether an interface or peer outside 127.0.0.0/8 is allowed (the module logs ROS2-OPEN when
  // it is). Off: such a config is refused before anything is created.
  bool allow_non_loopback = false;
  // SO_SNDBUF / SO_RCVBUF asked for the UDP sockets; 0: the system's default. Linux caps what a
  // process without CAP_NET_ADMIN gets at net.core.wmem_max / rmem_max.
  std::uint32_t socket_buffer_bytes = 0;
  std::string enclave = "/";  // the participant name and USER_DATA "enclave=/;" (rmw_fastrtps)
};

// What the read-back found, in words: what checkConfined judges.
struct ParticipantFacts {
  std::string discovery;  // "SIMPLE", "CLIENT", "SERVER", ...
  bool builtin_transports = false;
  struct Transport {
    std::string kind;  // "UDPv4", "UDPv6", "SHM", "TCPv4", ...
    std::vector<std::string> whitelist;
  };
  std::vector<Transport> transports;
  // "address:port" of every locator list of the QoS.
  std::vector<std::string> unicast_locators;
  std::vector<std::string> multicast_locators;
  std::vector<std::string> initial_peers;
  bool intraprocess_off = false;  // the process's library setting
};

// Errc::permission_denied "ROS2-NOT-CONFINED <what>" unless `facts` are: SIMPLE discovery, no
// builtin transport, exactly one UDPv4 transport whose whitelist is config.interfaces, no
// multicast locator, every unicast locator and peer on a configured interface or peer.
[[nodiscard]] Result<void> checkConfined(const ParticipantFacts& facts,
                                         const ParticipantConfig& config);
// Errc::permission_denied naming the variable when the environment would change discovery
// behind the QoS (ROS_DISCOVERY_SERVER, FASTDDS_ENVIRONMENT_FILE).
[[nodiscard]] Result<void> checkEnvironment();

using Gid = std::array<std::uint8_t, 16>;

// A sample's identity (RTPS: its writer's GUID and sequence number): ROS 2's request/reply over
// Fast DDS pairs a reply with its request by it (rmw_fastrtps).
// A GUID as ROS 2's graph information and request headers carry it: 12 bytes of prefix, 4 of
// entity id.
struct SampleIdentity {
  Gid writer{};
  std::int64_t sequence = 0;
  [[nodiscard]] bool valid() const noexcept { return sequence > 0; }
};

struct Sample {
  std::string bytes;        // CDR with its 4-byte encapsulation header
  SampleIdentity identity;  // this sample's
  SampleIdentity related;   // the related sample identity its writer gave (requests, replies)
  std::string writer_guid;  // "01.0f.….|0.0.1.3"
  std::int64_t source_timestamp_ns = 0;
  std::int64_t reception_timestamp_ns = 0;
  std::uint64_t sequence = 0;  // the writer's sequence number
};

struct MatchStatus {
  std::int32_t current = 0;  // endpoints matched now
  std::int32_t change = 0;   // +1 matched, -1 unmatched
  std::string remote_guid;
};

struct IncompatibleQos {
  std::string policy;  // "reliability", "durability", "deadline", ... (the last one found)
  std::uint32_t total = 0;
};

struct RemoteParticipant {
  enum class Change : std::uint8_t { discovered, changed, removed, dropped };
  Change change = Change::discovered;
  std::string guid, name;
  std::vector<std::string> unicast_locators, multicast_locators;  // metatraffic and default
};

struct WriterCallbacks {
  std::function<void(const MatchStatus&)> on_matched;
  std::function<void(const IncompatibleQos&)> on_incompatible_qos;
};

struct ReaderCallbacks {
  std::function<void(Sample&&)> on_sample;
  std::function<void(const MatchStatus&)> on_matched;
  std::function<void(const IncompatibleQos&)> on_incompatible_qos;
};

using EndpointId = std::uint64_t;

class DdsParticipant {
 public:
  // Checks config and environment, loads the XML profiles once (then intra-process delivery
  // off), creates the participant and reads its QoS back. `on_participant`: remote participants
  // discovered and gone (Fast DDS threads).
  [[nodiscard]] static Result<std::unique_ptr<DdsParticipant>> create(
      const ParticipantConfig& config,
      std::function<void(const RemoteParticipant&)> on_participant = {});
  // Deletes every endpoint and the participant: Fast DDS's threads of this participant are
  // joined when it returns. The process-wide log thread is stopped with the last participant.
  ~DdsParticipant();
  DdsParticipant(const DdsParticipant&) = delete;
  DdsParticipant& operator=(const DdsParticipant&) = delete;

  // A writer of `ros_type` ("pkg/msg/Name") on the ROS topic `ros_topic` ("/chatter": DDS topic
  // "rt/chatter", type "pkg::msg::dds_::Name_"). Errc::invalid_argument for a bad name or QoS.
  [[nodiscard]] Result<EndpointId> createWriter(std::string_view ros_topic,
                                                std::string_view ros_type, const Qos& qos,
                                                WriterCallbacks callbacks = {});
  [[nodiscard]] Result<EndpointId> createReader(std::string_view ros_topic,
                                                std::string_view ros_type, const Qos& qos,
                                                ReaderCallbacks callbacks);
  // The same under a DDS topic and type name used as they are (ros_discovery_info is not a ROS
  // topic: no rt/ prefix).
  [[nodiscard]] Result<EndpointId> createDdsWriter(const std::string& dds_topic,
                                                   const std::string& dds_type, const Qos& qos,
                                                   WriterCallbacks callbacks = {});
  [[nodiscard]] Result<EndpointId> createDdsReader(const std::string& dds_topic,
                                                   const std::string& dds_type, const Qos& qos,
                                                   ReaderCallbacks callbacks);
  // The GUID of an endpoint (zeros for an unknown one), and of the participant.
  [[nodiscard]] Gid gid(EndpointId id) const;
  [[nodiscard]] Gid participantGid() const;
  // Writes one sample (CDR with its header, not copied before Fast DDS serializes it).
  // Errc::timeout when a reliable writer's history stayed full; Errc::invalid_argument for
  // fewer than 4 bytes.
  [[nodiscard]] Result<void> write(EndpointId writer, std::string_view cdr);
  // Writes one sample with a related sample identity (a request: the client's reply reader; a
  // reply: the request it answers), and gives the identity it was written with.
  [[nodiscard]] Result<SampleIdentity> writeRelated(EndpointId writer, std::string_view cdr,
                                                    const SampleIdentity& related);
  // Waits until every matched reliable reader acknowledged what the writer sent.
  [[nodiscard]] Result<void> waitForAcknowledgments(EndpointId writer, std::int64_t timeout_ms);
  // Deletes a writer or a reader (and its topic when unused): none of its callbacks runs after.
  Result<void> deleteEndpoint(EndpointId id);

  [[nodiscard]] std::string guid() const;
  [[nodiscard]] const ParticipantFacts& facts() const noexcept;

  struct Impl;

 private:
  explicit DdsParticipant(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace skr::ros2_bridge
