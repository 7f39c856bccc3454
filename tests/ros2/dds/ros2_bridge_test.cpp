// SPDX-License-Identifier: Apache-2.0
// The ros2-bridge module in a real hub against a Fast DDS participant of the test's own (the
// ROS 2 side), in a network namespace of its own (own_netns.h): an exported channel reaches a
// ROS 2 reader as CDR while, and only while, one is matched; an imported topic reaches a
// satellite as CDR and as JSON; bad samples and incompatible QoS are counted and said; a bad
// config is reported with its paths and the hub goes on.
#include "dds_participant.h"
#include "graph_info.h"
#include "ros2_test_support.h"
#include "sat_fixture.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>
#include <skrobot/media_frame.hpp>
#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <list>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace skr::sat::test;
using namespace skr::ros2_bridge;
namespace ros2 = skr::ros2;
using skr::ros2::test::cdr;
using skr::ros2::test::json;
using skr::ros2::test::shipped;

// "01.0f.78.fd.11.60.f7.50.00.00.00.00|0.0.1.3" (Fast DDS's GUID text) as a Gid.
Gid gidOf(const std::string& text) {
  Gid out{};
  std::size_t i = 0;
  std::string part;
  for (char c : text + ".") {
    if (c == '.' || c == '|') {
      if (i < out.size()) out[i++] = static_cast<std::uint8_t>(std::stoul(part, nullptr, 16));
      part.clear();
    } else {
      part.push_back(c);
    }
  }
  return out;
}

// Samples a test participant's reader received.
struct Received {
  std::mutex m;
  std::vector<std::string> samples;
  int matched = 0;
  std::string remote;  // the GUID of the last endpoint matched
  std::string incompatible;
  std::size_t count() {
    std::lock_guard lock(m);
    return samples.size();
  }
};

class Ros2Bridge : public SatTest {
 protected:
  void SetUp() override { ASSERT_TRUE(skr::test::inOwnNetworkNamespace()); }

  // A hub with the bridge configured with `config` (its "config" object).
  void startBridge(const std::string& config) {
    hub_ = std::make_unique<HubProcess>(SKROBOT_BIN, dir_.path(), "", "", "",
                                        R"([{"name": "ros2-bridge", "config": )" + config + "}]");
    startHub();
    ASSERT_TRUE(hub_->waitLog("ROS2-BRIDGE")) << hub_->log();
  }
  // The ROS 2 side: a confined Fast DDS participant, as a ROS 2 node's would be.
  void startRos() {
    auto p = DdsParticipant::create(ParticipantConfig{});
    ASSERT_TRUE(p) << p.error().message;
    ros_ = std::move(*p);
  }
  EndpointId reader(const std::string& topic, const std::string& type, Received& into,
                    const Qos& qos = *qosProfile("default")) {
    ReaderCallbacks cb;
    cb.on_sample = [&into](Sample&& s) {
      std::lock_guard lock(into.m);
      into.samples.push_back(std::move(s.bytes));
    };
    cb.on_matched = [&into](const MatchStatus& m) {
      std::lock_guard lock(into.m);
      into.matched = m.current;
      into.remote = m.remote_guid;
    };
    auto id = ros_->createReader(topic, type, qos, std::move(cb));
    EXPECT_TRUE(id) << id.error().message;
    return id ? *id : 0;
  }
  EndpointId writer(const std::string& topic, const std::string& type, Received& matches,
                    const Qos& qos = *qosProfile("default")) {
    WriterCallbacks cb;
    cb.on_matched = [&matches](const MatchStatus& m) {
      std::lock_guard lock(matches.m);
      matches.matched = m.current;
      matches.remote = m.remote_guid;
    };
    cb.on_incompatible_qos = [&matches](const IncompatibleQos& q) {
      std::lock_guard lock(matches.m);
      matches.incompatible = q.policy;
    };
    auto id = ros_->createWriter(topic, type, qos, std::move(cb));
    EXPECT_TRUE(id) << id.error().message;
    return id ? *id : 0;
  }
  // A reader of ros_discovery_info (the graph), as ROS 2's tools read it.
  Received& graphReader() {
    Received& graph = received();
    ReaderCallbacks cb;
    cb.on_sample = [&graph](Sample&& s) {
      std::lock_guard lock(graph.m);
      graph.samples.push_back(std::move(s.bytes));
    };
    auto id = ros_->createDdsReader(kGraphTopic, kGraphType, graphQos(), std::move(cb));
    EXPECT_TRUE(id) << id.error().message;
    return graph;
  }
  static bool matched(Received& r, int n = 1) {
    return eventually([&] {
      std::lock_guard lock(r.m);
      return r.matched >= n;
    });
  }
  // The bridge's status, once a satellite hears it.
  Json::Value status(SatOnThread& sat) {
    std::string text;
    EXPECT_TRUE(eventually([&] {
      auto lines = sat.events.with("data:ros2-bridge.status:");
      if (lines.empty()) return false;
      text = lines.back();
      return true;
    })) << hub_->log();
    return json(text);
  }

  // What a test's DDS endpoints report into: kept by the fixture until its participant is gone
  // (a callback may come after the test's body, when the bridge deletes an endpoint).
  Received& received() { return received_.emplace_back(); }

  void TearDown() override { ros_.reset(); }

  std::unique_ptr<DdsParticipant> ros_;
  std::list<Received> received_;  // destroyed after ros_
};

TEST_F(Ros2Bridge, AnExportedChannelReachesRosReadersOnlyWhileOneIsMatched) {
  startBridge(R"({"export": [{"channel": "guest.cmd_vel", "ros": "/cmd_vel",
                              "type": "geometry_msgs/msg/Twist", "encoding": "json"}]})");
  auto sat = satellite("teleop");
  sat->on([](skr::sat::Satellite& s) {
    (void)s.addChannel({.name = "cmd_vel", .mime = "application/json"});
  });
  ASSERT_TRUE(eventually([&] { return sat->events.count("ready:guest.cmd_vel") == 1; }));
  startRos();
  // No ROS 2 reader yet: the bridge does not subscribe (the channel's owner is told to wait).
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  EXPECT_EQ(sat->events.count("start:guest.cmd_vel"), 0u) << sat->events.dump();
  Received& got = received();
  const EndpointId r = reader("/cmd_vel", "geometry_msgs/msg/Twist", got);
  ASSERT_TRUE(matched(got)) << hub_->log();
  ASSERT_TRUE(eventually([&] { return sat->events.count("start:guest.cmd_vel") == 1; }))
      << sat->events.dump() << hub_->log();
  const char* values[] = {R"({"linear": {"x": 0.25}})", R"({"angular": {"z": -1.5}})",
                          R"({"linear": {"x": 1, "y": 2, "z": 3}})"};
  for (const char* v : values) {
    sat->on([&](skr::sat::Satellite& s) { (void)s.publish("cmd_vel", v); });
  }
  ASSERT_TRUE(eventually([&] { return got.count() == 3; })) << hub_->log();
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(got.samples[i], cdr("geometry_msgs/msg/Twist", values[i])) << i;
  }
  // A message that is not a Twist is counted, not sent.
  sat->on([&](skr::sat::Satellite& s) { (void)s.publish("cmd_vel", R"({"linaer": {}})"); });
  ASSERT_TRUE(
      hub_->waitLog("ROS2-MALFORMED /cmd_vel: geometry_msgs/msg/Twist.linaer: no such "
                    "field in geometry_msgs/msg/Twist"))
      << hub_->log();
  // The reader goes: so does the bridge's subscription.
  ASSERT_TRUE(ros_->deleteEndpoint(r));
  EXPECT_TRUE(eventually([&] { return sat->events.count("stop:guest.cmd_vel") == 1; }))
      << sat->events.dump();
  EXPECT_EQ(got.count(), 3u);
}

TEST_F(Ros2Bridge, AnImportedTopicReachesSatellitesAsCdrAndAsJson) {
  startBridge(R"({"import": [
      {"ros": "/scan", "type": "sensor_msgs/msg/LaserScan", "encoding": "json"},
      {"ros": "/scan", "channel": "scan_cdr", "type": "sensor_msgs/msg/LaserScan"}]})");
  auto sat = satellite("reader");
  sat->on([](skr::sat::Satellite& s) {
    s.subscribe("ros2-bridge.scan");
    s.subscribe("ros2-bridge.scan_cdr");
    s.subscribe("ros2-bridge.status");
  });
  startRos();
  Received& matches = received();
  const EndpointId w = writer("/scan", "sensor_msgs/msg/LaserScan", matches);
  ASSERT_TRUE(matched(matches, 2)) << hub_->log();  // the bridge's two readers
  // Ranges of odd and even counts: what follows a sequence is aligned from where it ends.
  const std::string scans[] = {
      R"({"header": {"stamp": {"sec": 7, "nanosec": 5}, "frame_id": "laser"},
          "angle_min": -1.5, "angle_max": 1.5, "ranges": [1, 2.5, 3], "intensities": [9]})",
      R"({"header": {"frame_id": "l"}, "ranges": [0.5, 0.25], "intensities": []})"};
  for (const auto& s : scans) ASSERT_TRUE(ros_->write(w, cdr("sensor_msgs/msg/LaserScan", s)));
  ASSERT_TRUE(eventually([&] {
    return sat->events.count("data:ros2-bridge.scan:") == 2 &&
           sat->events.count("data:ros2-bridge.scan_cdr:") == 2;
  })) << sat->events.dump()
      << hub_->log();
  const auto as_json = sat->events.with("data:ros2-bridge.scan:");
  const auto as_cdr = sat->events.with("data:ros2-bridge.scan_cdr:");
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(
        skr::support::writeJson(json(as_json[i])),
        skr::support::writeJson(*ros2::cdrToJson(shipped(), "sensor_msgs/msg/LaserScan",
                                                 cdr("sensor_msgs/msg/LaserScan", scans[i]))));
    EXPECT_EQ(as_cdr[i], cdr("sensor_msgs/msg/LaserScan", scans[i]));
  }
  // The cdr channel says what it carries, with the schema a recording needs.
  const auto props = sat->on([](skr::sat::Satellite& s) {
    const auto* c = s.channel(std::string_view("ros2-bridge.scan_cdr"));
    return c != nullptr ? skr::flow::variantToJsonText(c->props) : std::string();
  });
  const Json::Value p = json(props);
  EXPECT_EQ(p["message_encoding"].asString(), "cdr");
  EXPECT_EQ(p["schema_name"].asString(), "sensor_msgs/msg/LaserScan");
  EXPECT_EQ(p["schema_encoding"].asString(), "ros2msg");
  EXPECT_EQ(p["schema"].asString(), shipped().schemaText("sensor_msgs/msg/LaserScan"));
  EXPECT_EQ(p["ros_topic"].asString(), "/scan");
  const Json::Value s = status(*sat);
  ASSERT_EQ(s["topics"].size(), 2u) << skr::support::writeJson(s);
  EXPECT_EQ(s["topics"][0]["messages"].asUInt64(), 2u) << skr::support::writeJson(s);
  EXPECT_EQ(s["topics"][0]["matched"].asInt(), 1) << skr::support::writeJson(s);
}

TEST_F(Ros2Bridge, AnImportedTopicIsReadOnlyWhileTheHubSubscribes) {
  startBridge(R"({"import": [{"ros": "/camera/image_raw", "type": "sensor_msgs/msg/Image",
                              "encoding": "media", "qos": {"profile": "sensor_data"}}]})");
  startRos();
  Received& matches = received();
  const EndpointId w =
      writer("/camera/image_raw", "sensor_msgs/msg/Image", matches, *qosProfile("sensor_data"));
  // Nobody reads the channel: the bridge has no reader, the camera's images go nowhere.
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  {
    std::lock_guard lock(matches.m);
    EXPECT_EQ(matches.matched, 0);
  }
  auto sat = satellite("viewer");
  sat->on([](skr::sat::Satellite& s) { s.subscribe("ros2-bridge.camera.image_raw"); });
  ASSERT_TRUE(matched(matches)) << hub_->log();
  const std::string image = cdr("sensor_msgs/msg/Image",
                                R"({"height": 1, "width": 1, "encoding": "mono8", "step": 1,
                                    "data": [7]})");
  ASSERT_TRUE(eventually([&] {
    (void)ros_->write(w, image);  // best effort: until one arrives
    return sat->events.count("data:ros2-bridge.camera.image_raw:") > 0;
  })) << hub_->log();
  sat->on([](skr::sat::Satellite& s) { s.unsubscribe("ros2-bridge.camera.image_raw"); });
  EXPECT_TRUE(eventually([&] {
    std::lock_guard lock(matches.m);
    return matches.matched == 0;
  })) << hub_->log();
}

// A latched topic (transient_local, as tf2's static broadcasters write /tf_static): what its
// writers kept before the bridge started reaches every hub subscriber that comes later, one
// sample per writer, and a writer's goes when the writer does.
TEST_F(Ros2Bridge, LatchedSamplesReachHubSubscribersThatComeLater) {
  startRos();
  Qos latched = *qosProfile("default");
  latched.durability = Durability::transient_local;
  latched.depth = 1;
  Received& arm_matches = received();
  Received& base_matches = received();
  const EndpointId arm = writer("/tf_static", "tf2_msgs/msg/TFMessage", arm_matches, latched);
  const EndpointId base = writer("/tf_static", "tf2_msgs/msg/TFMessage", base_matches, latched);
  auto tf = [](const char* child, double x) {
    return cdr("tf2_msgs/msg/TFMessage",
               std::string(R"({"transforms": [{"header": {"frame_id": "world"},
                               "child_frame_id": ")") +
                   child + R"(", "transform": {"translation": {"x": )" + std::to_string(x) +
                   "}}}]}");
  };
  ASSERT_TRUE(ros_->write(arm, tf("arm", 1)));
  ASSERT_TRUE(ros_->write(base, tf("base", 2)));
  ASSERT_TRUE(ros_->write(arm, tf("arm", 3)));  // keep_last 1: replaces the first
  startBridge(R"({"import": [{"ros": "/tf_static", "type": "tf2_msgs/msg/TFMessage",
                              "qos": {"durability": "transient_local", "depth": 1}}]})");
  auto watcher = satellite("watcher");
  watcher->on([](skr::sat::Satellite& s) { s.subscribe("ros2-bridge.status"); });
  // The bridge read both writers' kept samples, with nobody subscribed yet.
  Json::Value st;
  ASSERT_TRUE(eventually([&] {
    st = status(*watcher);
    return st["topics"][0]["messages"].asUInt64() == 2 && st["topics"][0]["matched"].asInt() == 2;
  })) << skr::support::writeJson(st)
      << hub_->log();
  auto firstSamples = [&](const std::string& name, std::size_t expected) {
    auto sat = satellite(name);
    sat->on([](skr::sat::Satellite& s) { s.subscribe("ros2-bridge.tf_static"); });
    EXPECT_TRUE(eventually([&] {
      return sat->events.count("data:ros2-bridge.tf_static:") >= expected;
    })) << sat->events.dump();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // and no more
    return sat->events.with("data:ros2-bridge.tf_static:");
  };
  // Each writer's last (the arm's second, not its first); the order between writers is the
  // order their histories reached the bridge.
  std::vector<std::string> both{tf("base", 2), tf("arm", 3)};
  std::sort(both.begin(), both.end());
  for (const char* name : {"late", "later"}) {
    auto got = firstSamples(name, 2);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, both) << name;
  }
  // The base's broadcaster goes: its transform is no longer kept.
  ASSERT_TRUE(ros_->deleteEndpoint(base));
  ASSERT_TRUE(eventually([&] {
    st = status(*watcher);
    return st["topics"][0]["matched"].asInt() == 1;
  })) << skr::support::writeJson(st);
  const auto got = firstSamples("last", 1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], tf("arm", 3));
  // The channel says so.
  const auto props = watcher->on([](skr::sat::Satellite& s) {
    const auto* c = s.channel(std::string_view("ros2-bridge.tf_static"));
    return c != nullptr ? skr::flow::variantToJsonText(c->props) : std::string();
  });
  EXPECT_TRUE(json(props)["retained"].asBool()) << props;
}

TEST_F(Ros2Bridge, BadSamplesAndIncompatibleQosAreCountedAndSaid) {
  startBridge(R"({"import": [{"ros": "/cmd_vel", "type": "geometry_msgs/msg/Twist"},
                             {"ros": "/odom_in", "type": "nav_msgs/msg/Odometry"}]})");
  auto sat = satellite("reader");
  sat->on([](skr::sat::Satellite& s) {
    s.subscribe("ros2-bridge.cmd_vel");
    s.subscribe("ros2-bridge.odom_in");  // read while subscribed
    s.subscribe("ros2-bridge.status");
  });
  startRos();
  Received& matches = received();
  // A writer that says Twist and sends a String's bytes (a node built against another type).
  const EndpointId w = writer("/cmd_vel", "geometry_msgs/msg/Twist", matches);
  ASSERT_TRUE(matched(matches)) << hub_->log();
  ASSERT_TRUE(ros_->write(w, cdr("std_msgs/msg/String", R"({"data": "not a twist"})")));
  ASSERT_TRUE(
      hub_->waitLog("ROS2-MALFORMED /cmd_vel: geometry_msgs/msg/Twist.linear.z: the "
                    "sample ends"))
      << hub_->log();
  // A good one after it still goes through.
  ASSERT_TRUE(ros_->write(w, cdr("geometry_msgs/msg/Twist", R"({"linear": {"x": 2}})")));
  ASSERT_TRUE(eventually([&] { return sat->events.count("data:ros2-bridge.cmd_vel:") == 1; }))
      << hub_->log();
  EXPECT_EQ(sat->events.with("data:ros2-bridge.cmd_vel:")[0],
            cdr("geometry_msgs/msg/Twist", R"({"linear": {"x": 2}})"));
  // A best-effort writer cannot serve the bridge's reliable reader: both sides say so.
  Received& odom = received();
  Qos best_effort = *qosProfile("sensor_data");
  (void)writer("/odom_in", "nav_msgs/msg/Odometry", odom, best_effort);
  ASSERT_TRUE(
      hub_->waitLog("ROS2-QOS-INCOMPATIBLE /odom_in: a remote writer disagrees with our "
                    "reader on reliability"))
      << hub_->log();
  EXPECT_TRUE(eventually([&] {
    std::lock_guard lock(odom.m);
    return odom.incompatible == "reliability";
  }));
  Json::Value s;
  EXPECT_TRUE(eventually([&] {
    s = status(*sat);
    return s["topics"][0]["malformed"].asUInt64() == 1 &&
           s["topics"][1]["incompatible_qos"].asString() == "reliability";
  })) << skr::support::writeJson(s);
}

TEST_F(Ros2Bridge, AnExportPatternFollowsTheChannelsItMatches) {
  startBridge(R"({"export": [{"channel": "guest.robot*", "ros": "/hub/{owner}/{name}",
                              "type": "geometry_msgs/msg/Twist", "encoding": "json"}]})");
  auto sat = satellite("fleet");
  sat->on([](skr::sat::Satellite& s) {
    for (const char* name : {"robot1", "robot-2", "other"}) {
      (void)s.addChannel({.name = name, .mime = "application/json"});
    }
  });
  ASSERT_TRUE(eventually([&] { return sat->events.count("ready:guest.other") == 1; }));
  startRos();
  Received& one = received();
  Received& two = received();
  Received& other = received();
  (void)reader("/hub/guest/robot1", "geometry_msgs/msg/Twist", one);
  (void)reader("/hub/guest/robot_2", "geometry_msgs/msg/Twist", two);  // '-' is not in ROS names
  (void)reader("/hub/guest/other", "geometry_msgs/msg/Twist", other);
  ASSERT_TRUE(matched(one) && matched(two)) << hub_->log();
  ASSERT_TRUE(eventually([&] {
    return sat->events.count("start:guest.robot1") == 1 &&
           sat->events.count("start:guest.robot-2") == 1;
  })) << sat->events.dump()
      << hub_->log();
  sat->on([](skr::sat::Satellite& s) {
    (void)s.publish("robot1", R"({"linear": {"x": 1}})");
    (void)s.publish("robot-2", R"({"linear": {"x": 2}})");
    (void)s.publish("other", R"({"linear": {"x": 3}})");
  });
  ASSERT_TRUE(eventually([&] { return one.count() == 1 && two.count() == 1; })) << hub_->log();
  EXPECT_EQ(one.samples[0], cdr("geometry_msgs/msg/Twist", R"({"linear": {"x": 1}})"));
  EXPECT_EQ(two.samples[0], cdr("geometry_msgs/msg/Twist", R"({"linear": {"x": 2}})"));
  EXPECT_NE(hub_->log().find("ROS2-EXPORT guest.robot1 exported to /hub/guest/robot1 as "
                             "geometry_msgs/msg/Twist (guest.robot*)"),
            std::string::npos)
      << hub_->log();
  // A channel the pattern does not match has no writer; one that goes takes its writer along,
  // and one that comes later gets its own.
  {
    std::lock_guard lock(other.m);
    EXPECT_EQ(other.matched, 0);
  }
  EXPECT_EQ(sat->events.count("start:guest.other"), 0u);
  sat->on([](skr::sat::Satellite& s) { (void)s.removeChannel("robot-2"); });
  EXPECT_TRUE(eventually([&] {
    std::lock_guard lock(two.m);
    return two.matched == 0;
  })) << hub_->log();
  // ROS 2's graph follows: the bridge's node lists the writers it has now.
  Received& graph = graphReader();
  ros2::Registry types;
  ASSERT_TRUE(types.addSchema(kGraphRosType, graphSchema(Distribution::jazzy)));
  auto writersListed = [&] {
    std::lock_guard lock(graph.m);
    if (graph.samples.empty()) return -1;
    auto info = ros2::cdrToJson(types, kGraphRosType, graph.samples.back());
    return info ? static_cast<int>((*info)["node_entities_info_seq"][0]["writer_gid_seq"].size())
                : -2;
  };
  EXPECT_TRUE(eventually([&] { return writersListed() == 1; })) << writersListed();
  Received& three = received();
  (void)reader("/hub/guest/robot3", "geometry_msgs/msg/Twist", three);
  sat->on([](skr::sat::Satellite& s) {
    (void)s.addChannel({.name = "robot3", .mime = "application/json"});
  });
  ASSERT_TRUE(matched(three)) << hub_->log();
  ASSERT_TRUE(eventually([&] { return sat->events.count("start:guest.robot3") == 1; }));
  sat->on([](skr::sat::Satellite& s) { (void)s.publish("robot3", R"({"angular": {"z": 1}})"); });
  EXPECT_TRUE(eventually([&] { return three.count() == 1; })) << hub_->log();
  EXPECT_TRUE(eventually([&] { return writersListed() == 2; })) << writersListed();
}

TEST_F(Ros2Bridge, ImagesGoBothWaysAsMediaFrames) {
  startBridge(R"({"export": [{"channel": "guest.camera", "ros": "/camera/image_raw",
                              "type": "sensor_msgs/msg/Image", "encoding": "media",
                              "frame_id": "camera_link"}],
                  "import": [{"ros": "/camera/image/compressed", "channel": "jpeg",
                              "type": "sensor_msgs/msg/CompressedImage", "encoding": "media"},
                             {"ros": "/depth", "type": "sensor_msgs/msg/Image",
                              "encoding": "media"}]})");
  auto cam = satellite("cam");
  cam->on([](skr::sat::Satellite& s) {
    (void)s.addChannel({.name = "camera", .mime = "application/octet-stream"});
  });
  auto viewer = satellite("viewer");
  viewer->on([](skr::sat::Satellite& s) {
    s.subscribe("ros2-bridge.jpeg");
    s.subscribe("ros2-bridge.depth");
  });
  ASSERT_TRUE(eventually([&] { return cam->events.count("ready:guest.camera") == 1; }));
  startRos();
  // A camera's raw frame reaches a ROS 2 reader as a sensor_msgs/msg/Image.
  Received& images = received();
  (void)reader("/camera/image_raw", "sensor_msgs/msg/Image", images);
  ASSERT_TRUE(matched(images)) << hub_->log();
  ASSERT_TRUE(eventually([&] { return cam->events.count("start:guest.camera") == 1; }));
  std::string px(4 * 2 * 3, '\0');
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = static_cast<char>(i);
  const std::string frame =
      *skr::media::makeRawFrame(skr::media::Format::rgb8, 4, 2, px, 9, 1'800'000'000'000'000'042);
  cam->on([&](skr::sat::Satellite& s) { (void)s.publish("camera", frame); });
  ASSERT_TRUE(eventually([&] { return images.count() == 1; })) << hub_->log();
  const Json::Value image = *ros2::cdrToJson(shipped(), "sensor_msgs/msg/Image", images.samples[0]);
  EXPECT_EQ(image["header"]["frame_id"].asString(), "camera_link");
  EXPECT_EQ(image["header"]["stamp"]["sec"].asInt64(), 1'800'000'000);
  EXPECT_EQ(image["header"]["stamp"]["nanosec"].asInt64(), 42);
  EXPECT_EQ(image["encoding"].asString(), "rgb8");
  EXPECT_EQ(image["width"].asInt(), 4);
  EXPECT_EQ(image["step"].asInt(), 12);
  EXPECT_EQ(image["data"].size(), px.size());
  EXPECT_EQ(image["data"][23].asInt(), 23);

  // A ROS 2 node's JPEG and its depth image reach a satellite as media frames.
  Received& jpeg_matches = received();
  Received& depth_matches = received();
  const EndpointId jw =
      writer("/camera/image/compressed", "sensor_msgs/msg/CompressedImage", jpeg_matches);
  const EndpointId dw = writer("/depth", "sensor_msgs/msg/Image", depth_matches);
  ASSERT_TRUE(matched(jpeg_matches) && matched(depth_matches)) << hub_->log();
  const std::string jpeg = std::string(
      "\xFF\xD8\xFF\xC0\x00\x0B\x08\x01\xE0\x02\x80\x01\x01"
      "\x11\x00\xFF\xD9",
      17);  // a frame header of 640x480, and its end
  Json::Value compressed = json(R"({"header": {"stamp": {"sec": 5, "nanosec": 6}},
                                    "format": "jpeg"})");
  for (char c : jpeg) compressed["data"].append(static_cast<unsigned char>(c));
  ASSERT_TRUE(ros_->write(jw, ros2::test::cdrOf("sensor_msgs/msg/CompressedImage", compressed)));
  ASSERT_TRUE(ros_->write(dw, cdr("sensor_msgs/msg/Image",
                                  R"({"header": {"stamp": {"sec": 1}}, "height": 2, "width": 1,
                  "encoding": "mono16", "step": 4, "data": [1, 2, 0, 0, 3, 4, 0, 0]})")));
  compressed["format"] = "png";
  ASSERT_TRUE(ros_->write(jw, ros2::test::cdrOf("sensor_msgs/msg/CompressedImage", compressed)));
  ASSERT_TRUE(eventually([&] {
    return viewer->events.count("data:ros2-bridge.jpeg:") == 1 &&
           viewer->events.count("data:ros2-bridge.depth:") == 1;
  })) << viewer->events.dump()
      << hub_->log();
  auto got = skr::media::parseFrame(viewer->events.with("data:ros2-bridge.jpeg:")[0]);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->header.format, skr::media::Format::jpeg);
  EXPECT_EQ(got->header.width, 640);
  EXPECT_EQ(got->header.height, 480);
  EXPECT_EQ(got->header.capture_ns, 5'000'000'006);
  EXPECT_EQ(got->payload, jpeg);
  got = skr::media::parseFrame(viewer->events.with("data:ros2-bridge.depth:")[0]);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->header.format, skr::media::Format::mono16);
  EXPECT_EQ(got->payload, std::string("\x01\x02\x03\x04", 4));  // the rows' padding gone
  ASSERT_TRUE(
      hub_->waitLog("ROS2-MALFORMED /camera/image/compressed: "
                    "sensor_msgs/msg/CompressedImage: format \"png\" is not JPEG"))
      << hub_->log();
  // The depth channel says what its frames are once it has seen one.
  EXPECT_TRUE(eventually([&] {
    const auto props = viewer->on([](skr::sat::Satellite& s) {
      const auto* c = s.channel(std::string_view("ros2-bridge.depth"));
      return c != nullptr ? skr::flow::variantToJsonText(c->props) : std::string();
    });
    const Json::Value p = json(props);
    return p["encoding"].asString() == "mono16" && p["width"].asInt() == 1 &&
           p["height"].asInt() == 2 && p["message_encoding"].asString() == "skrobot.media";
  })) << hub_->log();
}

#ifdef CYCLONE_PEER
// A node on another DDS (Cyclone DDS, cyclone_peer: its own types from IDL) and a satellite talk
// through the bridge, both ways.
TEST_F(Ros2Bridge, ACycloneDdsNodeAndASatelliteTalkThroughTheBridge) {
  startBridge(R"({"import": [{"ros": "/chatter", "type": "std_msgs/msg/String",
                              "encoding": "json"}],
                  "export": [{"channel": "guest.cmd_vel", "ros": "/cmd_vel",
                              "type": "geometry_msgs/msg/Twist", "encoding": "json"}]})");
  auto sat = satellite("teleop");
  sat->on([](skr::sat::Satellite& s) {
    s.subscribe("ros2-bridge.chatter");
    (void)s.addChannel({.name = "cmd_vel", .mime = "application/json"});
  });
  Child talker({CYCLONE_PEER, "pub", "--topic", "rt/chatter", "--type", "std_msgs/msg/String",
                "--count", "5", "--period-ms", "20"},
               {}, dir_.path() / "talker.log");
  EXPECT_EQ(talker.wait(30000), 0) << talker.output() << hub_->log();
  ASSERT_TRUE(eventually([&] { return sat->events.count("data:ros2-bridge.chatter:") == 5; }))
      << sat->events.dump() << hub_->log();
  const auto heard = sat->events.with("data:ros2-bridge.chatter:");
  for (std::size_t i = 0; i < heard.size(); ++i) {
    EXPECT_EQ(json(heard[i])["data"].asString(), "hello " + std::to_string(i + 1));
  }
  Child listener({CYCLONE_PEER, "sub", "--topic", "rt/cmd_vel", "--type", "geometry_msgs/msg/Twist",
                  "--count", "2"},
                 {}, dir_.path() / "listener.log");
  ASSERT_TRUE(eventually([&] { return sat->events.count("start:guest.cmd_vel") == 1; }, 30000))
      << listener.output() << hub_->log();
  // The reader has matched the bridge's writer once the listener says so.
  ASSERT_TRUE(listener.waitOutput("matched", 30000)) << listener.output();
  sat->on([](skr::sat::Satellite& s) {
    (void)s.publish("cmd_vel", R"({"linear": {"x": 0.5}})");
    (void)s.publish("cmd_vel", R"({"linear": {"y": -2}, "angular": {"z": 1.25}})");
  });
  EXPECT_EQ(listener.wait(30000), 0) << listener.output();
  const std::string out = listener.output();
  EXPECT_NE(out.find(R"("linear":{"x":0.5,"y":0,"z":0})"), std::string::npos) << out;
  EXPECT_NE(out.find(R"("angular":{"x":0,"y":0,"z":1.25})"), std::string::npos) << out;
}
#endif

// ros_discovery_info: the bridge is a node whose readers and writers are the ones ROS 2 nodes
// match, in the layout of the configured distribution, read by a node that starts later.
TEST_F(Ros2Bridge, TheBridgeIsANodeInRos2sGraph) {
  for (const auto d : {Distribution::jazzy, Distribution::humble}) {
    const bool humble = d == Distribution::humble;
    startBridge(std::string(R"({"node": "hub_bridge", "namespace": "/lab", "distribution": ")") +
                (humble ? "humble" : "jazzy") + R"(",
        "import": [{"ros": "chatter", "type": "std_msgs/msg/String"}],
        "export": [{"channel": "guest.out", "ros": "/out", "type": "std_msgs/msg/String"}]})");
    auto sat = satellite("reader");
    sat->on([](skr::sat::Satellite& s) { s.subscribe("ros2-bridge.lab.chatter"); });
    startRos();
    Received& out = received();
    Received& chatter = received();
    (void)reader("/out", "std_msgs/msg/String", out);
    (void)writer("/lab/chatter", "std_msgs/msg/String", chatter);
    ASSERT_TRUE(matched(out) && matched(chatter)) << hub_->log();
    Received& graph = graphReader();
    ASSERT_TRUE(eventually([&] { return graph.count() >= 1; })) << hub_->log();
    ros2::Registry types;
    ASSERT_TRUE(types.addSchema(kGraphRosType, graphSchema(d)));
    auto info = ros2::cdrToJson(types, kGraphRosType, graph.samples[0]);
    ASSERT_TRUE(info) << info.error().message;
    const Json::Value& node = (*info)["node_entities_info_seq"][0];
    EXPECT_EQ(node["node_name"].asString(), "hub_bridge");
    EXPECT_EQ(node["node_namespace"].asString(), "/lab");
    auto asGid = [&](const Json::Value& g) {
      EXPECT_EQ(g["data"].size(), humble ? 24u : 16u);
      Gid out{};
      for (Json::ArrayIndex i = 0; i < g["data"].size(); ++i) {
        if (i < out.size()) {
          out[i] = static_cast<std::uint8_t>(g["data"][i].asUInt());
        } else {
          EXPECT_EQ(g["data"][i].asUInt(), 0u) << "Humble's gid is the GUID then zeros";
        }
      }
      return out;
    };
    ASSERT_EQ(node["writer_gid_seq"].size(), 1u);
    ASSERT_EQ(node["reader_gid_seq"].size(), 1u);
    std::lock_guard lock_out(out.m);
    std::lock_guard lock_chatter(chatter.m);
    EXPECT_EQ(asGid(node["writer_gid_seq"][0]), gidOf(out.remote)) << out.remote;
    EXPECT_EQ(asGid(node["reader_gid_seq"][0]), gidOf(chatter.remote)) << chatter.remote;
    const Gid participant = asGid((*info)["gid"]);
    EXPECT_TRUE(
        std::equal(participant.begin(), participant.begin() + 12, gidOf(out.remote).begin()));
    ros_.reset();
    hub_->stop();
    hub_.reset();
  }
}

// Services as rmw_fastrtps makes them (rq/<name>Request, rr/<name>Reply; the request names the
// client's reply reader in its related sample identity, the reply names the request): a hub
// service answers a ROS 2 client, and a hub request reaches a ROS 2 server.
TEST_F(Ros2Bridge, ServicesGoBothWaysWithRmwFastrtpsRequestsAndReplies) {
  startBridge(R"({
      "services_export": [
        {"channel": "guest.adder", "command": "add", "ros": "/add_two_ints",
         "type": "example_interfaces/srv/AddTwoInts"},
        {"channel": "guest.absent", "ros": "/trigger", "type": "std_srvs/srv/Trigger"}],
      "services_import": [
        {"ros": "/sum", "type": "example_interfaces/srv/AddTwoInts", "timeout_ms": 1500}]})");
  auto sat = satellite("services");
  ASSERT_TRUE(sat->on([](skr::sat::Satellite& s) {
    s.serviceRequest.connect(&s, [&s](const skr::sat::Request& r) {
      const auto* a = r.value.find("a");
      const auto* b = r.value.find("b");
      const std::int64_t sum =
          (a && a->asInt64() ? *a->asInt64() : 0) + (b && b->asInt64() ? *b->asInt64() : 0);
      (void)s.respond(r, r.command == "add" ? skr::flow::Variant::Map{{"sum", sum}}
                                            : skr::flow::Variant::Map{{"wrong", r.command}});
    });
    return static_cast<bool>(
        s.addChannel({.name = "adder", .kind = skr::flow::ChannelKind::service}));
  }));
  startRos();
  const std::string req = "example_interfaces::srv::dds_::AddTwoInts_Request_";
  const std::string rep = "example_interfaces::srv::dds_::AddTwoInts_Response_";
  const Qos services = *qosProfile("services");

  // A ROS 2 client of /add_two_ints: the hub service answers (the command is the config's).
  Received& client_writer = received();
  Received& replies = received();
  ReaderCallbacks rcb;
  std::vector<Sample> reply_samples;
  std::mutex reply_mutex;
  rcb.on_sample = [&](Sample&& s) {
    std::lock_guard lock(reply_mutex);
    reply_samples.push_back(std::move(s));
  };
  rcb.on_matched = [&](const MatchStatus& m) {
    std::lock_guard lock(replies.m);
    replies.matched = m.current;
  };
  WriterCallbacks wcb;
  wcb.on_matched = [&](const MatchStatus& m) {
    std::lock_guard lock(client_writer.m);
    client_writer.matched = m.current;
  };
  auto reply_reader = ros_->createDdsReader("rr/add_two_intsReply", rep, services, rcb);
  auto request_writer = ros_->createDdsWriter("rq/add_two_intsRequest", req, services, wcb);
  ASSERT_TRUE(reply_reader && request_writer);
  ASSERT_TRUE(matched(client_writer) && matched(replies)) << hub_->log();
  auto sent = ros_->writeRelated(
      *request_writer, cdr("example_interfaces/srv/AddTwoInts_Request", R"({"a": 2, "b": 40})"),
      SampleIdentity{ros_->gid(*reply_reader), 0});
  ASSERT_TRUE(sent) << sent.error().message;
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(reply_mutex);
    return !reply_samples.empty();
  })) << hub_->log();
  {
    std::lock_guard lock(reply_mutex);
    const Sample& r = reply_samples[0];
    EXPECT_EQ(r.related.writer, ros_->gid(*reply_reader));
    EXPECT_EQ(r.related.sequence, sent->sequence);
    EXPECT_EQ(r.bytes, cdr("example_interfaces/srv/AddTwoInts_Response", R"({"sum": 42})"));
  }

  // /trigger's hub service does not exist: a Trigger's reply says so (success false).
  Received& trigger_writer = received();
  Received& trigger_replies = received();
  std::vector<std::string> trigger_samples;
  ReaderCallbacks tcb;
  tcb.on_sample = [&](Sample&& s) {
    std::lock_guard lock(trigger_replies.m);
    trigger_replies.samples.push_back(std::move(s.bytes));
  };
  tcb.on_matched = [&](const MatchStatus& m) {
    std::lock_guard lock(trigger_replies.m);
    trigger_replies.matched = m.current;
  };
  WriterCallbacks twcb;
  twcb.on_matched = [&](const MatchStatus& m) {
    std::lock_guard lock(trigger_writer.m);
    trigger_writer.matched = m.current;
  };
  auto trigger_reader = ros_->createDdsReader(
      "rr/triggerReply", "std_srvs::srv::dds_::Trigger_Response_", services, tcb);
  auto trigger_request = ros_->createDdsWriter(
      "rq/triggerRequest", "std_srvs::srv::dds_::Trigger_Request_", services, twcb);
  ASSERT_TRUE(trigger_reader && trigger_request);
  ASSERT_TRUE(matched(trigger_writer) && matched(trigger_replies)) << hub_->log();
  ASSERT_TRUE(ros_->writeRelated(*trigger_request, cdr("std_srvs/srv/Trigger_Request", "{}"),
                                 SampleIdentity{ros_->gid(*trigger_reader), 0}));
  ASSERT_TRUE(eventually([&] { return trigger_replies.count() == 1; })) << hub_->log();
  auto trigger =
      ros2::cdrToJson(shipped(), "std_srvs/srv/Trigger_Response", trigger_replies.samples[0]);
  ASSERT_TRUE(trigger);
  EXPECT_FALSE((*trigger)["success"].asBool());
  EXPECT_NE((*trigger)["message"].asString().find("guest.absent"), std::string::npos)
      << skr::support::writeJson(*trigger);

  // The hub calls /sum: no server yet, then a ROS 2 server that answers, then one that does not.
  auto call = [&](std::int64_t a, std::int64_t b) {
    sat->events.clear();
    EXPECT_TRUE(sat->on([&](skr::sat::Satellite& s) {
      return static_cast<bool>(
          s.request("ros2-bridge.sum", "call", skr::flow::Variant::Map{{"a", a}, {"b", b}}));
    }));
    std::string answer;
    EXPECT_TRUE(eventually([&] {
      auto r = sat->events.with("response:");
      if (r.empty()) return false;
      answer = r[0];
      return true;
    })) << hub_->log();
    return answer.substr(answer.find(':') + 1);
  };
  EXPECT_NE(call(1, 2).find(R"("error":"no_server")"), std::string::npos);
  std::mutex server_mutex;
  std::vector<Sample> requests;
  ReaderCallbacks scb;
  scb.on_sample = [&](Sample&& s) {
    std::lock_guard lock(server_mutex);
    requests.push_back(std::move(s));
  };
  Received& server_replies = received();
  WriterCallbacks swcb;
  swcb.on_matched = [&](const MatchStatus& m) {
    std::lock_guard lock(server_replies.m);
    server_replies.matched = m.current;
  };
  auto server_reader = ros_->createDdsReader("rq/sumRequest", req, services, scb);
  auto server_writer = ros_->createDdsWriter("rr/sumReply", rep, services, swcb);
  ASSERT_TRUE(server_reader && server_writer);
  ASSERT_TRUE(matched(server_replies)) << hub_->log();
  // The bridge counts its request writer's matches: wait until it sees the server.
  ASSERT_TRUE(eventually([&] {
    sat->on([](skr::sat::Satellite& s) { s.subscribe("ros2-bridge.status"); });
    auto st = sat->events.with("data:ros2-bridge.status:");
    return !st.empty() && json(st.back())["services"][0]["matched"].asInt() == 1;
  })) << sat->events.dump()
      << hub_->log();
  std::atomic<bool> serving{true};
  std::thread server([&] {  // the server's loop: DdsParticipant is used from one thread at a time
    while (serving) {
      std::vector<Sample> todo;
      {
        std::lock_guard lock(server_mutex);
        todo.swap(requests);
      }
      for (const Sample& q : todo) {
        auto v = ros2::cdrToJson(shipped(), "example_interfaces/srv/AddTwoInts_Request", q.bytes);
        if (!v || (*v)["a"].asInt64() < 0) continue;  // a < 0: no answer (the timeout case)
        const SampleIdentity to{q.related.writer != Gid{} ? q.related.writer : q.identity.writer,
                                q.identity.sequence};
        (void)ros_->writeRelated(
            *server_writer,
            cdr("example_interfaces/srv/AddTwoInts_Response",
                R"({"sum": )" + std::to_string((*v)["a"].asInt64() + (*v)["b"].asInt64()) + "}"),
            to);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  EXPECT_EQ(call(6, 7), R"({"sum":13})");
  EXPECT_EQ(call(100, -1), R"({"sum":99})");
  EXPECT_NE(call(-1, 0).find(R"("error":"timeout")"), std::string::npos);
  serving = false;
  server.join();
}

TEST_F(Ros2Bridge, ABadConfigIsReportedWithItsPathsAndTheHubGoesOn) {
  hub_ = std::make_unique<HubProcess>(SKROBOT_BIN, dir_.path(), "", "", "",
                                      R"([{"name": "ros2-bridge", "config": {"import": [
            {"ros": "/scan", "type": "sensor_msgs/LaserScan", "qos": {"profile": "fast"},
             "frame_id": "laser"},
            {"ros": "bad//name", "type": "nosuch", "encoding": "xml", "colour": 1}],
          "export": [{"ros": "/x", "type": "std_msgs/msg/String"},
                     {"channel": "guest.*", "ros": "/hub/cmd", "type": "std_msgs/msg/String"},
                     {"channel": "a.b", "ros": "/y", "type": "std_msgs/msg/String",
                      "encoding": "media"}]}}])");
  startHub();
  const std::string log = hub_->log();
  for (const char* line : {
           "import[0].qos.profile: must be default, sensor_data, services or system",
           "import[1].ros: ",
           "import[1].type: not a ROS 2 message type (pkg/msg/Name)",
           "import[1].encoding: must be cdr, json or media",
           "import[1].colour: unknown key",
           "export[0].channel: is required",
           "export[1].ros: a pattern's channels need topics of their own",
           "export[2].encoding: media carries sensor_msgs/msg/Image and "
           "sensor_msgs/msg/CompressedImage only (std_msgs/msg/String is cdr or json)",
           "import[0].frame_id: only media exports set a frame_id",
       }) {
    EXPECT_NE(log.find(line), std::string::npos) << line << "\n" << log;
  }
  EXPECT_NE(log.find("MODULE-INIT module ros2-bridge"), std::string::npos) << log;
  // The hub goes on: a satellite connects.
  auto sat = satellite("after");
  EXPECT_TRUE(sat->connected());
}

}  // namespace

int main(int argc, char** argv) {
  return skr::ros2::test::runInOwnNamespace(argc, argv);
}
