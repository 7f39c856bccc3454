// SPDX-License-Identifier: Apache-2.0
// fastdds_peer: a ROS 2-style DDS peer on eProsima Fast DDS (Debian's 2.9, the DDS of ROS 2's
// default middleware) with the types fastddsgen generated from tests/ros2/idl (committed in
// fastdds_gen/): what a ROS 2 node on rmw_fastrtps puts on the wire, without the project's ROS 2
// code. Its command line and output are cyclone_peer's:
//
//   fastdds_peer pub|sub --topic rt/chatter --type std_msgs/msg/String [--count N]
//       [--period-ms MS] [--reliability reliable|best_effort]
//       [--durability volatile|transient_local] [--depth N] [--domain D] [--timeout-ms MS]
//       [--width W] [--height H]   (sensor_msgs/msg/Image: the picture's size, default 640x480)
//       [--matched N]   (wait for N matched endpoints before going on, default 1)
//
// pub: waits for --matched readers and prints {"event":"matched","after_ms":T}, then writes
// --count samples (sequence numbers 1..N, a value per type: see the fill functions) one every
// --period-ms, waits for their acknowledgments (reliable) and prints {"event":"done","sent":N}.
// sub: prints {"event":"matched","after_ms":T} when a writer matched, then one line per sample,
// {"type":"std_msgs/msg/String","value":{"data":"hello 3"}}, with every field; an Image's data
// is printed as "data_size" and "data_fnv1a" (FNV-1a 32 of its bytes), not byte by byte.
// Exit status: 0 done, 2 bad usage, 3 no match or too few samples within --timeout-ms (default
// 20000), 1 a DDS error or a participant that is not confined.
//
// Confinement (../shared/DDS-LOOPBACK.md): the participant's QoS is built in code, never from
// an XML profile: one UDPv4 transport whose whitelist is 127.0.0.1, the builtin transports off
// (no shared memory), unicast metatraffic and default locators and the initial peer at
// 127.0.0.1, no multicast locator. The peer reads its participant's QoS back and exits (1)
// unless all of that holds. QoS defaults: ROS 2's default profile (reliable, volatile,
// keep_last 10), set explicitly since Fast DDS's own defaults differ.

#include "builtin_interfaces/msg/TimePubSubTypes.h"
#include "geometry_msgs/msg/TwistPubSubTypes.h"
#include "sensor_msgs/msg/ImagePubSubTypes.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "std_msgs/msg/StringPubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace dds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
using eprosima::fastrtps::types::ReturnCode_t;
using rtps::IPLocator;

constexpr const char* kLoopback = "127.0.0.1";

// --- JSON output (cyclone_peer's formats) --------------------------------------------------------

void putString(std::string& out, const std::string& s) {
  out += '"';
  for (const unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  out += '"';
}

// JSON has no NaN or infinity: null, as the project's cdrToJson writes them.
void putDouble(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "null";
    return;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  out += buf;
}

// %.9g gives back the same float when parsed as a double and rounded to float.
void putFloat(std::string& out, float v) {
  if (!std::isfinite(v)) {
    out += "null";
    return;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(v));
  out += buf;
}

void putFloats(std::string& out, const std::vector<float>& values) {
  out += '[';
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) out += ',';
    putFloat(out, values[i]);
  }
  out += ']';
}

void putTime(std::string& out, const builtin_interfaces::msg::dds_::Time_& t) {
  out +=
      "{\"sec\":" + std::to_string(t.sec()) + ",\"nanosec\":" + std::to_string(t.nanosec()) + "}";
}

void putHeader(std::string& out, const std_msgs::msg::dds_::Header_& h) {
  out += "{\"stamp\":";
  putTime(out, h.stamp());
  out += ",\"frame_id\":";
  putString(out, h.frame_id());
  out += '}';
}

void putVector3(std::string& out, const geometry_msgs::msg::dds_::Vector3_& v) {
  out += "{\"x\":";
  putDouble(out, v.x());
  out += ",\"y\":";
  putDouble(out, v.y());
  out += ",\"z\":";
  putDouble(out, v.z());
  out += '}';
}

void putQuaternion(std::string& out, const geometry_msgs::msg::dds_::Quaternion_& q) {
  out += "{\"x\":";
  putDouble(out, q.x());
  out += ",\"y\":";
  putDouble(out, q.y());
  out += ",\"z\":";
  putDouble(out, q.z());
  out += ",\"w\":";
  putDouble(out, q.w());
  out += '}';
}

// FNV-1a, 32 bits: an Image's bytes in a few characters (the test computes the same).
std::uint32_t fnv1a(const std::vector<std::uint8_t>& bytes) {
  std::uint32_t h = 2166136261u;
  for (const std::uint8_t b : bytes) h = (h ^ b) * 16777619u;
  return h;
}

// --- the types, their values and their JSON ---------------------------------------------------
// n: the sample's sequence number, from 1.

struct Options;

struct PeerType {
  const char* ros_name;
  std::function<dds::TopicDataType*()> make_type;
  // A new sample (the generated class) with the n-th value; deleted by delete_data.
  std::function<void*(const Options&, std::uint32_t n)> make_sample;
  std::function<void(void*)> delete_sample;
  std::function<void(std::string& out, const void* sample)> print;
};

struct Options {
  bool publish = false;
  std::string topic;
  const PeerType* type = nullptr;
  long count = 10, period_ms = 100, depth = 10, domain = 0, timeout_ms = 20000;
  long width = 640, height = 480, matched = 1;
  bool reliable = true, transient_local = false;
};

using builtin_interfaces::msg::dds_::Time_;
using geometry_msgs::msg::dds_::Twist_;
using sensor_msgs::msg::dds_::Image_;
using sensor_msgs::msg::dds_::LaserScan_;
using std_msgs::msg::dds_::String_;
using tf2_msgs::msg::dds_::TFMessage_;

Time_ timeValue(std::uint32_t n) {
  Time_ t;
  t.sec(1700000000 + static_cast<std::int32_t>(n));
  t.nanosec(250000000u + n);
  return t;
}

// cyclone_peer's values for String, Twist and LaserScan.
String_ stringValue(std::uint32_t n) {
  String_ s;
  s.data("hello " + std::to_string(n));
  return s;
}

Twist_ twistValue(std::uint32_t n) {
  Twist_ t;
  t.linear().x(n);
  t.linear().y(0.5);
  t.linear().z(-0.25);
  t.angular().z(0.1 * n);
  return t;
}

// n ranges (0.5 + 0.25 i) and n intensities (100 + i), at most 1024.
LaserScan_ laserScanValue(std::uint32_t n) {
  if (n > 1024) n = 1024;
  LaserScan_ s;
  s.header().stamp(timeValue(n));
  s.header().frame_id("laser");
  s.angle_min(-1.5f);
  s.angle_max(1.5f);
  s.angle_increment(0.01f);
  s.time_increment(0.0001f);
  s.scan_time(0.1f);
  s.range_min(0.05f);
  s.range_max(30.0f);
  for (std::uint32_t i = 0; i < n; ++i) {
    s.ranges().push_back(0.5f + 0.25f * static_cast<float>(i));
    s.intensities().push_back(100.0f + static_cast<float>(i));
  }
  return s;
}

// An rgb8 picture of --width x --height, frame "camera"; byte i is (i + 3n) % 251 (a prime, so
// that rows and frames differ).
Image_ imageValue(const Options& o, std::uint32_t n) {
  Image_ img;
  img.header().stamp(timeValue(n));
  img.header().frame_id("camera");
  img.width(static_cast<std::uint32_t>(o.width));
  img.height(static_cast<std::uint32_t>(o.height));
  img.encoding("rgb8");
  img.is_bigendian(0);
  img.step(static_cast<std::uint32_t>(o.width * 3));
  auto& data = img.data();
  data.resize(static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height) * 3);
  for (std::size_t i = 0; i < data.size(); ++i) {
    data[i] = static_cast<std::uint8_t>((i + 3u * n) % 251u);
  }
  return img;
}

// Two transforms: map -> odom (translation (n, 0.5, -0.25), a turn of 0.1 n rad about z) and
// odom -> base_link (translation (0.1 n, 0, 0), no turn), stamped as timeValue(n).
TFMessage_ tfValue(std::uint32_t n) {
  TFMessage_ tf;
  geometry_msgs::msg::dds_::TransformStamped_ a;
  a.header().stamp(timeValue(n));
  a.header().frame_id("map");
  a.child_frame_id("odom");
  a.transform().translation().x(n);
  a.transform().translation().y(0.5);
  a.transform().translation().z(-0.25);
  a.transform().rotation().z(std::sin(0.05 * n));
  a.transform().rotation().w(std::cos(0.05 * n));
  geometry_msgs::msg::dds_::TransformStamped_ b;
  b.header().stamp(timeValue(n));
  b.header().frame_id("odom");
  b.child_frame_id("base_link");
  b.transform().translation().x(0.1 * n);
  b.transform().rotation().w(1.0);
  tf.transforms() = {a, b};
  return tf;
}

void printString(std::string& out, const void* sample) {
  out += "{\"data\":";
  putString(out, static_cast<const String_*>(sample)->data());
  out += '}';
}

void printTwist(std::string& out, const void* sample) {
  const auto& t = *static_cast<const Twist_*>(sample);
  out += "{\"linear\":";
  putVector3(out, t.linear());
  out += ",\"angular\":";
  putVector3(out, t.angular());
  out += '}';
}

void printLaserScan(std::string& out, const void* sample) {
  const auto& s = *static_cast<const LaserScan_*>(sample);
  const std::pair<const char*, float> floats[] = {{"angle_min", s.angle_min()},
                                                  {"angle_max", s.angle_max()},
                                                  {"angle_increment", s.angle_increment()},
                                                  {"time_increment", s.time_increment()},
                                                  {"scan_time", s.scan_time()},
                                                  {"range_min", s.range_min()},
                                                  {"range_max", s.range_max()}};
  out += "{\"header\":";
  putHeader(out, s.header());
  for (const auto& [name, value] : floats) {
    out += ",\"" + std::string(name) + "\":";
    putFloat(out, value);
  }
  out += ",\"ranges\":";
  putFloats(out, s.ranges());
  out += ",\"intensities\":";
  putFloats(out, s.intensities());
  out += '}';
}

void printImage(std::string& out, const void* sample) {
  const auto& img = *static_cast<const Image_*>(sample);
  out += "{\"header\":";
  putHeader(out, img.header());
  out +=
      ",\"height\":" + std::to_string(img.height()) + ",\"width\":" + std::to_string(img.width());
  out += ",\"encoding\":";
  putString(out, img.encoding());
  out += ",\"is_bigendian\":" + std::to_string(img.is_bigendian()) +
         ",\"step\":" + std::to_string(img.step()) +
         ",\"data_size\":" + std::to_string(img.data().size()) +
         ",\"data_fnv1a\":" + std::to_string(fnv1a(img.data())) + "}";
}

void printTf(std::string& out, const void* sample) {
  const auto& tf = *static_cast<const TFMessage_*>(sample);
  out += "{\"transforms\":[";
  for (std::size_t i = 0; i < tf.transforms().size(); ++i) {
    const auto& t = tf.transforms()[i];
    if (i > 0) out += ',';
    out += "{\"header\":";
    putHeader(out, t.header());
    out += ",\"child_frame_id\":";
    putString(out, t.child_frame_id());
    out += ",\"transform\":{\"translation\":";
    putVector3(out, t.transform().translation());
    out += ",\"rotation\":";
    putQuaternion(out, t.transform().rotation());
    out += "}}";
  }
  out += "]}";
}

// A PeerType for generated type T (T_PubSubType P) with its value and printer.
template <typename T, typename P>
PeerType peerType(const char* name, std::function<T(const Options&, std::uint32_t)> value,
                  void (*print)(std::string&, const void*)) {
  return PeerType{
      name, [] { return new P(); },
      [value](const Options& o, std::uint32_t n) -> void* { return new T(value(o, n)); },
      [](void* s) { delete static_cast<T*>(s); }, print};
}

const std::vector<PeerType>& types() {
  static const std::vector<PeerType> all = {
      peerType<String_, std_msgs::msg::dds_::String_PubSubType>(
          "std_msgs/msg/String", [](const Options&, std::uint32_t n) { return stringValue(n); },
          printString),
      peerType<Twist_, geometry_msgs::msg::dds_::Twist_PubSubType>(
          "geometry_msgs/msg/Twist", [](const Options&, std::uint32_t n) { return twistValue(n); },
          printTwist),
      peerType<LaserScan_, sensor_msgs::msg::dds_::LaserScan_PubSubType>(
          "sensor_msgs/msg/LaserScan",
          [](const Options&, std::uint32_t n) { return laserScanValue(n); }, printLaserScan),
      peerType<Image_, sensor_msgs::msg::dds_::Image_PubSubType>("sensor_msgs/msg/Image",
                                                                 imageValue, printImage),
      peerType<TFMessage_, tf2_msgs::msg::dds_::TFMessage_PubSubType>(
          "tf2_msgs/msg/TFMessage", [](const Options&, std::uint32_t n) { return tfValue(n); },
          printTf),
  };
  return all;
}

// --- command line --------------------------------------------------------------------------------

int usage(const std::string& why) {
  std::fprintf(stderr,
               "fastdds_peer: %s\nusage: fastdds_peer pub|sub --topic rt/NAME --type pkg/msg/Type "
               "[--count N] [--period-ms MS] [--reliability reliable|best_effort] [--durability "
               "volatile|transient_local] [--depth N] [--domain D] [--timeout-ms MS] [--width W] "
               "[--height H] [--matched N]\ntypes:",
               why.c_str());
  for (const auto& t : types()) std::fprintf(stderr, " %s", t.ros_name);
  std::fputc('\n', stderr);
  return 2;
}

bool parseLong(const char* text, long min, long max, long& out) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0' || v < min || v > max) return false;
  out = v;
  return true;
}

int parseOptions(int argc, char** argv, Options& o) {
  if (argc < 2) return usage("pub or sub?");
  const std::string mode = argv[1];
  if (mode != "pub" && mode != "sub") return usage("the first argument is pub or sub");
  o.publish = mode == "pub";
  for (int i = 2; i < argc; i += 2) {
    const std::string name = argv[i];
    if (i + 1 >= argc) return usage("an option without its value");
    const char* value = argv[i + 1];
    const std::string v = value;
    bool ok = true;
    if (name == "--topic") {
      o.topic = v;
    } else if (name == "--type") {
      for (const auto& t : types()) {
        if (v == t.ros_name) o.type = &t;
      }
      ok = o.type != nullptr;
    } else if (name == "--count") {
      ok = parseLong(value, 1, 1000000, o.count);
    } else if (name == "--period-ms") {
      ok = parseLong(value, 0, 3600000, o.period_ms);
    } else if (name == "--depth") {
      ok = parseLong(value, 1, 100000, o.depth);
    } else if (name == "--domain") {
      ok = parseLong(value, 0, 232, o.domain);
    } else if (name == "--timeout-ms") {
      ok = parseLong(value, 1, 3600000, o.timeout_ms);
    } else if (name == "--width") {
      ok = parseLong(value, 1, 8192, o.width);
    } else if (name == "--height") {
      ok = parseLong(value, 1, 8192, o.height);
    } else if (name == "--matched") {
      ok = parseLong(value, 1, 100, o.matched);
    } else if (name == "--reliability") {
      ok = v == "reliable" || v == "best_effort";
      o.reliable = v == "reliable";
    } else if (name == "--durability") {
      ok = v == "volatile" || v == "transient_local";
      o.transient_local = v == "transient_local";
    } else {
      return usage("unknown option " + name);
    }
    if (!ok) return usage("bad value for " + name + ": " + v);
  }
  if (o.topic.empty() || o.type == nullptr) return usage("--topic and --type are required");
  return 0;
}

// --- confinement ---------------------------------------------------------------------------------

rtps::Locator_t loopbackLocator() {
  rtps::Locator_t l;
  l.kind = LOCATOR_KIND_UDPv4;
  l.port = 0;  // Fast DDS picks the well-known ports
  IPLocator::setIPv4(l, kLoopback);
  return l;
}

dds::DomainParticipantQos confinedQos() {
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList = {kLoopback};
  udp->maxInitialPeersRange = 20;  // participant ids 0..19 on 127.0.0.1, as cyclone_peer
  dds::DomainParticipantQos qos;   // fresh: not the factory's default, which XML may change
  qos.name("fastdds_peer");
  qos.transport().use_builtin_transports = false;
  qos.transport().user_transports = {udp};
  auto& builtin = qos.wire_protocol().builtin;
  builtin.discovery_config.discoveryProtocol = rtps::DiscoveryProtocol_t::SIMPLE;
  builtin.avoid_builtin_multicast = true;
  builtin.metatrafficMulticastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(loopbackLocator());
  builtin.initialPeersList.clear();
  builtin.initialPeersList.push_back(loopbackLocator());
  qos.wire_protocol().default_multicast_locator_list.clear();
  qos.wire_protocol().default_unicast_locator_list.clear();
  qos.wire_protocol().default_unicast_locator_list.push_back(loopbackLocator());
  return qos;
}

// Empty when the participant's QoS, as read back, is confined to loopback; else what is not.
std::string notConfined(const dds::DomainParticipantQos& qos) {
  if (const char* v = std::getenv("ROS_DISCOVERY_SERVER"); v != nullptr && *v != '\0') {
    return "ROS_DISCOVERY_SERVER is set";
  }
  const auto& builtin = qos.wire_protocol().builtin;
  if (builtin.discovery_config.discoveryProtocol != rtps::DiscoveryProtocol_t::SIMPLE) {
    return "discovery is not SIMPLE";
  }
  if (qos.transport().use_builtin_transports) return "builtin transports on";
  if (qos.transport().user_transports.size() != 1) return "not one user transport";
  const auto udp = std::dynamic_pointer_cast<eprosima::fastdds::rtps::UDPv4TransportDescriptor>(
      qos.transport().user_transports.front());
  if (!udp) return "the transport is not UDPv4";
  if (udp->interfaceWhiteList != std::vector<std::string>{kLoopback}) {
    return "the UDPv4 whitelist is not {127.0.0.1}";
  }
  if (!builtin.metatrafficMulticastLocatorList.empty() ||
      !qos.wire_protocol().default_multicast_locator_list.empty()) {
    return "a multicast locator";
  }
  const rtps::LocatorList_t* lists[] = {&builtin.metatrafficUnicastLocatorList,
                                        &builtin.initialPeersList,
                                        &qos.wire_protocol().default_unicast_locator_list};
  for (const auto* list : lists) {
    if (list->empty()) return "an empty unicast locator list";
    for (const auto& l : *list) {
      if (l.kind != LOCATOR_KIND_UDPv4 || IPLocator::toIPv4string(l) != kLoopback) {
        return "a locator that is not UDPv4 127.0.0.1: " + IPLocator::ip_to_string(l);
      }
    }
  }
  return {};
}

// --- pub and sub ---------------------------------------------------------------------------------

const auto kStart = std::chrono::steady_clock::now();

void printLine(const std::string& line) {
  std::fwrite(line.data(), 1, line.size(), stdout);
  std::fputc('\n', stdout);
  std::fflush(stdout);
}

void printMatched() {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                      std::chrono::steady_clock::now() - kStart)
                      .count();
  printLine("{\"event\":\"matched\",\"after_ms\":" + std::to_string(ms) + "}");
}

bool waitFor(const std::function<bool()>& done, std::chrono::steady_clock::time_point deadline) {
  while (!done()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

int runPub(const Options& o, dds::DataWriter* writer) {
  const auto deadline = kStart + std::chrono::milliseconds(o.timeout_ms);
  const bool matched = waitFor(
      [&] {
        dds::PublicationMatchedStatus st;
        return writer->get_publication_matched_status(st) == ReturnCode_t::RETCODE_OK &&
               st.current_count >= o.matched;
      },
      deadline);
  if (!matched) {
    std::fprintf(stderr, "fastdds_peer: fewer than %ld readers matched on %s within %ld ms\n",
                 o.matched, o.topic.c_str(), o.timeout_ms);
    return 3;
  }
  printMatched();
  auto next = std::chrono::steady_clock::now();
  long sent = 0;
  for (long n = 1; n <= o.count; ++n) {
    void* sample = o.type->make_sample(o, static_cast<std::uint32_t>(n));
    const bool ok = writer->write(sample);
    o.type->delete_sample(sample);
    if (!ok) {
      std::fprintf(stderr, "fastdds_peer: write %ld failed\n", n);
      return 1;
    }
    ++sent;
    if (n < o.count && o.period_ms > 0) {
      next += std::chrono::milliseconds(o.period_ms);  // absolute: no drift
      std::this_thread::sleep_until(next);
    }
  }
  if (o.reliable) {
    const auto rc = writer->wait_for_acknowledgments(
        eprosima::fastrtps::Duration_t(static_cast<double>(o.timeout_ms) / 1000.0));
    if (rc != ReturnCode_t::RETCODE_OK) {
      std::fprintf(stderr, "fastdds_peer: samples not acknowledged within %ld ms\n", o.timeout_ms);
      return 3;
    }
  }
  printLine("{\"event\":\"done\",\"sent\":" + std::to_string(sent) + "}");
  return 0;
}

int runSub(const Options& o, dds::DataReader* reader, dds::TopicDataType* type) {
  const auto deadline = kStart + std::chrono::milliseconds(o.timeout_ms);
  const bool matched = waitFor(
      [&] {
        dds::SubscriptionMatchedStatus st;
        return reader->get_subscription_matched_status(st) == ReturnCode_t::RETCODE_OK &&
               st.current_count >= o.matched;
      },
      deadline);
  if (!matched) {
    std::fprintf(stderr, "fastdds_peer: fewer than %ld writers matched on %s within %ld ms\n",
                 o.matched, o.topic.c_str(), o.timeout_ms);
    return 3;
  }
  printMatched();
  void* sample = type->createData();
  long received = 0;
  int status = 0;
  while (received < o.count) {
    dds::SampleInfo info;
    if (reader->take_next_sample(sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      std::string line = "{\"type\":";
      putString(line, o.type->ros_name);
      line += ",\"value\":";
      o.type->print(line, sample);
      line += '}';
      printLine(line);
      ++received;
      continue;
    }
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) {
      std::fprintf(stderr, "fastdds_peer: %ld of %ld samples on %s within %ld ms\n", received,
                   o.count, o.topic.c_str(), o.timeout_ms);
      status = 3;
      break;
    }
    const double wait_s =
        std::min(0.1, std::chrono::duration<double>(left).count());  // re-check the deadline
    (void)reader->wait_for_unread_message(eprosima::fastrtps::Duration_t(wait_s));
  }
  type->deleteData(sample);
  return status;
}

int runPeer(int argc, char** argv) {
  Options o;
  if (const int bad = parseOptions(argc, argv, o); bad != 0) return bad;

  auto* factory = dds::DomainParticipantFactory::get_instance();
  dds::DomainParticipant* participant =
      factory->create_participant(static_cast<dds::DomainId_t>(o.domain), confinedQos());
  if (participant == nullptr) {
    std::fprintf(stderr, "fastdds_peer: cannot create the participant\n");
    return 1;
  }
  int status = 1;
  if (const std::string why = notConfined(participant->get_qos()); !why.empty()) {
    std::fprintf(stderr, "fastdds_peer: not confined to loopback (%s); not starting\n",
                 why.c_str());
  } else {
    dds::TypeSupport type(o.type->make_type());
    dds::Topic* topic =
        type.register_type(participant) == ReturnCode_t::RETCODE_OK
            ? participant->create_topic(o.topic, type.get_type_name(), dds::TOPIC_QOS_DEFAULT)
            : nullptr;
    const auto reliability =
        o.reliable ? dds::RELIABLE_RELIABILITY_QOS : dds::BEST_EFFORT_RELIABILITY_QOS;
    const auto durability =
        o.transient_local ? dds::TRANSIENT_LOCAL_DURABILITY_QOS : dds::VOLATILE_DURABILITY_QOS;
    if (topic == nullptr) {
      std::fprintf(stderr, "fastdds_peer: cannot create topic %s (%s)\n", o.topic.c_str(),
                   type.get_type_name().c_str());
    } else if (o.publish) {
      dds::Publisher* publisher = participant->create_publisher(dds::PUBLISHER_QOS_DEFAULT);
      dds::DataWriterQos q = dds::DATAWRITER_QOS_DEFAULT;
      q.reliability().kind = reliability;
      q.durability().kind = durability;
      q.history().kind = dds::KEEP_LAST_HISTORY_QOS;
      q.history().depth = static_cast<std::int32_t>(o.depth);
      q.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
      q.data_sharing().off();
      dds::DataWriter* writer =
          publisher != nullptr ? publisher->create_datawriter(topic, q) : nullptr;
      if (writer == nullptr) {
        std::fprintf(stderr, "fastdds_peer: cannot create the writer of %s\n", o.topic.c_str());
      } else {
        status = runPub(o, writer);
      }
    } else {
      dds::Subscriber* subscriber = participant->create_subscriber(dds::SUBSCRIBER_QOS_DEFAULT);
      dds::DataReaderQos q = dds::DATAREADER_QOS_DEFAULT;
      q.reliability().kind = reliability;
      q.durability().kind = durability;
      q.history().kind = dds::KEEP_LAST_HISTORY_QOS;
      q.history().depth = static_cast<std::int32_t>(o.depth);
      q.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
      q.data_sharing().off();
      dds::DataReader* reader =
          subscriber != nullptr ? subscriber->create_datareader(topic, q) : nullptr;
      if (reader == nullptr) {
        std::fprintf(stderr, "fastdds_peer: cannot create the reader of %s\n", o.topic.c_str());
      } else {
        status = runSub(o, reader, type.get());
      }
    }
  }
  participant->delete_contained_entities();
  factory->delete_participant(participant);
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  return runPeer(argc, argv);
}
