// SPDX-License-Identifier: Apache-2.0
// ros2-bridge's DDS core (plugins/ros2-bridge/src: ros_names, raw_type, dds_participant) on
// real Fast DDS participants. The executable re-runs itself in a network namespace of its own
// (`unshare --net`, with --map-root-user when not root; then lo up), so that nothing it sends
// can leave the machine and parallel tests cannot discover each other. `--peer ...` runs the
// second process of a case (spawned by the case, in the same namespace).
#include "dds_participant.h"
#include "eventually.h"
#include "ros2_test_support.h"
#include "ros_names.h"
#include "temp_dir.h"

#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/definitions.h>

#include <gtest/gtest.h>
#include <fastdds/dds/log/Log.hpp>

#include <arpa/inet.h>
#include <dirent.h>
#include <net/if.h>
#include <netinet/in.h>
#include <spawn.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace {

using namespace skr::ros2_bridge;
using skr::ros2::test::multicastGroups;
using skr::test::eventually;

int threadCount() {
  int n = 0;
  DIR* dir = opendir("/proc/self/task");
  if (!dir) return -1;
  while (dirent* e = readdir(dir)) {
    if (e->d_name[0] != '.') ++n;
  }
  closedir(dir);
  return n;
}

std::int64_t nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// This process's UDP sockets: their local address, SO_RCVBUF and SO_SNDBUF.
struct SocketInfo {
  std::string address;
  int port = 0;
  int rcvbuf = 0, sndbuf = 0;
};
std::vector<SocketInfo> udpSockets() {
  std::vector<SocketInfo> out;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/fd")) {
    std::error_code ec;
    const auto target = std::filesystem::read_symlink(entry.path(), ec).string();
    if (ec || target.rfind("socket:", 0) != 0) continue;
    const int fd = std::atoi(entry.path().filename().c_str());
    int type = 0;
    socklen_t len = sizeof type;
    if (getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &len) != 0 || type != SOCK_DGRAM) continue;
    sockaddr_storage addr{};
    len = sizeof addr;
    if (getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) continue;
    SocketInfo info;
    if (addr.ss_family == AF_INET) {
      const auto* in = reinterpret_cast<const sockaddr_in*>(&addr);
      char text[INET_ADDRSTRLEN];
      inet_ntop(AF_INET, &in->sin_addr, text, sizeof text);
      info.address = text;
      info.port = ntohs(in->sin_port);
    } else {
      info.address = "family " + std::to_string(addr.ss_family);
    }
    len = sizeof info.rcvbuf;
    getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &info.rcvbuf, &len);
    len = sizeof info.sndbuf;
    getsockopt(fd, SOL_SOCKET, SO_SNDBUF, &info.sndbuf, &len);
    out.push_back(info);
  }
  return out;
}

skr::ros2::Registry stringRegistry() {
  skr::ros2::Registry registry;
  auto def = skr::ros2::parseMessage("std_msgs/msg/String", "string data\n");
  EXPECT_TRUE(def.ok());
  EXPECT_TRUE(registry.add(std::move(*def)).ok());
  return registry;
}

std::string stringSample(const std::string& text) {
  const auto registry = stringRegistry();
  Json::Value value;
  value["data"] = text;
  auto cdr = skr::ros2::jsonToCdr(registry, "std_msgs/msg/String", value);
  EXPECT_TRUE(cdr.ok()) << cdr.error().describe();
  return cdr.ok() ? *cdr : std::string();
}

pid_t spawnPeer(const std::vector<std::string>& args, int* stdout_fd = nullptr) {
  std::vector<std::string> all{skr::test::selfExe(), "--peer"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  int pipe_fds[2] = {-1, -1};
  if (stdout_fd) {
    if (pipe(pipe_fds) != 0) return -1;
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], 1);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
  }
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  if (stdout_fd) {
    close(pipe_fds[1]);
    *stdout_fd = pipe_fds[0];
  }
  return pid;
}

int waitExit(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// --- peers (the second process of a case) ---------------------------------------------------

// pub FILE: writes FILE's bytes once on /chatter (std_msgs/msg/String, default QoS) as soon as
// a reader matched, and waits for its acknowledgment. Exit 0, or 2 (no match), 3 (not acked).
int peerPublishOnce(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto participant = DdsParticipant::create(ParticipantConfig{});
  if (!participant) {
    std::cerr << participant.error().describe() << "\n";
    return 1;
  }
  std::atomic<int> matched{0};
  WriterCallbacks callbacks;
  callbacks.on_matched = [&](const MatchStatus& s) { matched = s.current; };
  auto writer =
      (*participant)
          ->createWriter("/chatter", "std_msgs/msg/String", *qosProfile("default"), callbacks);
  if (!writer) return 1;
  if (!eventually([&] { return matched > 0; }, 15000)) return 2;
  if (!(*participant)->write(*writer, bytes)) return 1;
  if (!(*participant)->waitForAcknowledgments(*writer, 10000)) return 3;
  return 0;
}

int runPeer(int argc, char** argv) {
  const std::vector<std::string> args(argv + 2, argv + argc);
  if (args.size() == 2 && args[0] == "pub") return peerPublishOnce(args[1]);
  std::cerr << "unknown peer command\n";
  return 64;
}

// --- names and QoS ---------------------------------------------------------------------------

TEST(RosNames, TopicsMapToRtNames) {
  EXPECT_EQ(*ddsTopicName("/chatter"), "rt/chatter");
  EXPECT_EQ(*ddsTopicName("/camera/image/compressed"), "rt/camera/image/compressed");
  EXPECT_EQ(*ddsTopicName("chatter", "/robot"), "rt/robot/chatter");
  EXPECT_EQ(*ddsTopicName("~/status", "/robot", "bridge"), "rt/robot/bridge/status");
  EXPECT_EQ(*ddsTopicName("~/status", "/", "bridge"), "rt/bridge/status");
  for (const char* bad : {"", "/", "/a//b", "/a/", "/a__b", "/9lives", "/a b", "/a-b", "~x"}) {
    auto r = ddsTopicName(bad, "/", "node");
    EXPECT_FALSE(r.ok()) << bad;
    if (!r.ok()) {
      EXPECT_EQ(r.error().code, skr::Errc::invalid_argument);
    }
  }
  EXPECT_FALSE(ddsTopicName("~/x").ok());            // no node to resolve '~' against
  EXPECT_FALSE(ddsTopicName("x", "relative").ok());  // the namespace must be absolute
  auto too_long = ddsTopicName("/" + std::string(253, 'a'));
  ASSERT_FALSE(too_long.ok());
  EXPECT_NE(too_long.error().message.find("at most 255"), std::string::npos);
}

TEST(Qos, RosProfilesAreSetInFull) {
  const Qos d = *qosProfile("default");
  EXPECT_EQ(describe(d), "reliable, volatile, keep_last 10");
  EXPECT_EQ(describe(*qosProfile("sensor_data")), "best_effort, volatile, keep_last 5");
  EXPECT_EQ(describe(*qosProfile("services")), "reliable, volatile, keep_last 10");
  EXPECT_FALSE(qosProfile("fast").has_value());
}

// --- confinement -----------------------------------------------------------------------------

ParticipantFacts confinedFacts() {
  ParticipantFacts facts;
  facts.discovery = "SIMPLE";
  facts.transports.push_back({"UDPv4", {"127.0.0.1"}});
  facts.unicast_locators = {"127.0.0.1"};
  facts.initial_peers = {"127.0.0.1"};
  facts.intraprocess_off = true;
  return facts;
}

void expectRefused(const skr::Result<void>& r, const std::string& words) {
  ASSERT_FALSE(r.ok()) << "not refused: " << words;
  EXPECT_EQ(r.error().code, skr::Errc::permission_denied);
  EXPECT_NE(r.error().message.find("ROS2-NOT-CONFINED"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(words), std::string::npos) << r.error().message;
}

TEST(Confinement, ReadBackRefusesWhatIsNotConfined) {
  const ParticipantConfig config;
  EXPECT_TRUE(checkConfined(confinedFacts(), config).ok());

  auto facts = confinedFacts();
  facts.multicast_locators = {"239.255.0.1:7400"};
  expectRefused(checkConfined(facts, config), "not confined: multicast locator 239.255.0.1");
  facts = confinedFacts();
  facts.discovery = "CLIENT";
  expectRefused(checkConfined(facts, config), "discovery CLIENT");
  facts = confinedFacts();
  facts.builtin_transports = true;
  expectRefused(checkConfined(facts, config), "builtin transports");
  facts = confinedFacts();
  facts.transports.push_back({"SHM", {}});
  expectRefused(checkConfined(facts, config), "transports [UDPv4, SHM]");
  facts = confinedFacts();
  facts.transports.front().whitelist.clear();  // an empty whitelist: every interface
  expectRefused(checkConfined(facts, config), "UDPv4 whitelist []");
  facts = confinedFacts();
  facts.unicast_locators.push_back("192.168.1.5:7410");
  expectRefused(checkConfined(facts, config), "unicast locator 192.168.1.5:7410");
  facts = confinedFacts();
  facts.initial_peers.push_back("10.0.0.7");
  expectRefused(checkConfined(facts, config), "initial peer 10.0.0.7");
  facts = confinedFacts();
  facts.intraprocess_off = false;
  expectRefused(checkConfined(facts, config), "intra-process");
}

TEST(Confinement, ConfigOffLoopbackIsRefusedBeforeCreation) {
  ParticipantConfig config;
  config.interfaces = {"192.168.1.5"};
  auto r = DdsParticipant::create(config);
  ASSERT_FALSE(r.ok());
  expectRefused(skr::Result<void>(r.error()), "interface 192.168.1.5 is not loopback");
  config = ParticipantConfig{};
  config.peers = {"239.255.0.1"};
  r = DdsParticipant::create(config);
  ASSERT_FALSE(r.ok());
  expectRefused(skr::Result<void>(r.error()), "peer 239.255.0.1 is a multicast address");
  config = ParticipantConfig{};
  config.interfaces = {"lo"};
  r = DdsParticipant::create(config);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, skr::Errc::invalid_argument) << r.error().describe();
}

TEST(Confinement, RosDiscoveryServerIsRefused) {
  // Fast DDS 2.9.1 would silently make the participant a discovery-server client (its QoS
  // still saying SIMPLE): refused before creation.
  ASSERT_EQ(setenv("ROS_DISCOVERY_SERVER", "127.0.0.1:11811", 1), 0);
  auto r = DdsParticipant::create(ParticipantConfig{});
  unsetenv("ROS_DISCOVERY_SERVER");
  ASSERT_FALSE(r.ok());
  expectRefused(skr::Result<void>(r.error()), "ROS_DISCOVERY_SERVER=127.0.0.1:11811 is set");
  ASSERT_EQ(setenv("FASTDDS_ENVIRONMENT_FILE", "/nonexistent/fastdds.json", 1), 0);
  r = DdsParticipant::create(ParticipantConfig{});
  unsetenv("FASTDDS_ENVIRONMENT_FILE");
  ASSERT_FALSE(r.ok());
  expectRefused(skr::Result<void>(r.error()), "FASTDDS_ENVIRONMENT_FILE");
}

TEST(Confinement, AnXmlProfileInTheWorkingDirectoryChangesNothing) {
  // DEFAULT_FASTRTPS_PROFILES.xml in the cwd, with multicast, every interface and intra-process
  // delivery on: the participant's QoS is built in code, the library settings after loading it.
  skr::test::TempDir dir("skrobot-dds-xml");
  std::ofstream(dir.path() / "DEFAULT_FASTRTPS_PROFILES.xml") << R"(<?xml version="1.0"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <library_settings><intraprocess_delivery>FULL</intraprocess_delivery></library_settings>
  <profiles>
    <participant profile_name="leaky" is_default_profile="true">
      <rtps><builtin><metatrafficMulticastLocatorList><locator><udpv4>
        <address>239.255.0.1</address><port>7400</port></udpv4></locator>
      </metatrafficMulticastLocatorList></builtin></rtps>
    </participant>
  </profiles>
</dds>
)";
  const auto cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir.path());
  auto participant = DdsParticipant::create(ParticipantConfig{});
  std::filesystem::current_path(cwd);
  ASSERT_TRUE(participant.ok()) << participant.error().describe();
  EXPECT_TRUE((*participant)->facts().intraprocess_off);
  EXPECT_TRUE((*participant)->facts().multicast_locators.empty());
  EXPECT_TRUE(multicastGroups().empty());
}

// --- samples between participants -------------------------------------------------------------

TEST(DdsCore, RawCdrCrossesToAnotherProcessByteForByte) {
  ASSERT_TRUE(skr::test::inOwnNetworkNamespace()) << "not in the test's network namespace";
  skr::test::TempDir dir("skrobot-dds");
  const std::string bytes = stringSample("hello from a Fast DDS peer");
  ASSERT_EQ(bytes.substr(0, 4), std::string("\x00\x01\x00\x00", 4));
  const auto file = (dir.path() / "sample.cdr").string();
  std::ofstream(file, std::ios::binary) << bytes;

  std::mutex mutex;
  std::vector<Sample> samples;
  std::vector<RemoteParticipant> remotes;
  auto participant = DdsParticipant::create(ParticipantConfig{}, [&](const RemoteParticipant& r) {
    std::lock_guard lock(mutex);
    remotes.push_back(r);
  });
  ASSERT_TRUE(participant.ok()) << participant.error().describe();
  // Latched: the peer writes, is acknowledged and exits (unmatching) as soon as it matched,
  // possibly between two polls.
  std::atomic<bool> matched{false};
  ReaderCallbacks callbacks;
  callbacks.on_sample = [&](Sample&& s) {
    std::lock_guard lock(mutex);
    samples.push_back(std::move(s));
  };
  callbacks.on_matched = [&](const MatchStatus& s) { matched = matched || s.current > 0; };
  auto reader =
      (*participant)
          ->createReader("/chatter", "std_msgs/msg/String", *qosProfile("default"), callbacks);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();

  const auto start = std::chrono::steady_clock::now();
  const pid_t peer = spawnPeer({"pub", file});
  ASSERT_GT(peer, 0);
  EXPECT_TRUE(eventually([&] { return matched.load(); }, 15000));
  const auto match_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                            std::chrono::steady_clock::now() - start)
                            .count();
  EXPECT_TRUE(eventually(
      [&] {
        std::lock_guard lock(mutex);
        return !samples.empty();
      },
      15000));
  const auto sample_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                             std::chrono::steady_clock::now() - start)
                             .count();
  EXPECT_EQ(waitExit(peer), 0);
  std::cout << "matched after " << match_ms << " ms, sample after " << sample_ms
            << " ms (the peer's start included)\n";

  std::lock_guard lock(mutex);
  ASSERT_EQ(samples.size(), 1u);
  EXPECT_EQ(samples[0].bytes, bytes);
  EXPECT_FALSE(samples[0].writer_guid.empty());
  EXPECT_NE(samples[0].writer_guid.substr(0, 35), (*participant)->guid().substr(0, 35));
  EXPECT_LT(std::llabs(samples[0].source_timestamp_ns - nowNs()), 60'000'000'000LL);
  // What the peer announced on the wire: unicast 127.0.0.1 only.
  ASSERT_FALSE(remotes.empty());
  EXPECT_EQ(remotes[0].change, RemoteParticipant::Change::discovered);
  EXPECT_EQ(remotes[0].name, "/");
  EXPECT_TRUE(remotes[0].multicast_locators.empty()) << remotes[0].multicast_locators[0];
  ASSERT_FALSE(remotes[0].unicast_locators.empty());
  for (const auto& l : remotes[0].unicast_locators) EXPECT_EQ(l.rfind("127.0.0.1:", 0), 0u) << l;
  // And this process: every UDP socket on 127.0.0.1, no multicast group joined.
  const auto sockets = udpSockets();
  ASSERT_FALSE(sockets.empty());
  for (const auto& s : sockets) EXPECT_EQ(s.address, "127.0.0.1") << "port " << s.port;
  EXPECT_TRUE(multicastGroups().empty()) << multicastGroups()[0];
}

TEST(DdsCore, IncompatibleQosIsReportedWithThePolicy) {
  auto a = DdsParticipant::create(ParticipantConfig{});
  ASSERT_TRUE(a.ok()) << a.error().describe();
  auto b = DdsParticipant::create(ParticipantConfig{});
  ASSERT_TRUE(b.ok()) << b.error().describe();
  std::mutex mutex;
  std::vector<std::string> writer_side, reader_side;
  std::atomic<int> matches{0};
  WriterCallbacks wc;
  wc.on_incompatible_qos = [&](const IncompatibleQos& q) {
    std::lock_guard lock(mutex);
    writer_side.push_back(q.policy);
  };
  wc.on_matched = [&](const MatchStatus&) { ++matches; };
  ReaderCallbacks rc;
  rc.on_incompatible_qos = [&](const IncompatibleQos& q) {
    std::lock_guard lock(mutex);
    reader_side.push_back(q.policy);
  };
  rc.on_matched = [&](const MatchStatus&) { ++matches; };
  rc.on_sample = [](Sample&&) {};
  auto writer =
      (*a)->createWriter("/scan", "sensor_msgs/msg/LaserScan", *qosProfile("sensor_data"), wc);
  ASSERT_TRUE(writer.ok());
  auto reader =
      (*b)->createReader("/scan", "sensor_msgs/msg/LaserScan", *qosProfile("default"), rc);
  ASSERT_TRUE(reader.ok());
  EXPECT_TRUE(eventually(
      [&] {
        std::lock_guard lock(mutex);
        return !writer_side.empty() && !reader_side.empty();
      },
      15000));
  std::lock_guard lock(mutex);
  ASSERT_FALSE(writer_side.empty());
  ASSERT_FALSE(reader_side.empty());
  EXPECT_EQ(writer_side[0], "reliability");
  EXPECT_EQ(reader_side[0], "reliability");
  EXPECT_EQ(matches.load(), 0);
}

TEST(DdsCore, TeardownLeavesNoThread) {
  const int before = threadCount();
  {
    auto a = DdsParticipant::create(ParticipantConfig{});
    ASSERT_TRUE(a.ok()) << a.error().describe();
    auto b = DdsParticipant::create(ParticipantConfig{});
    ASSERT_TRUE(b.ok()) << b.error().describe();
    std::atomic<int> received{0}, matched{0}, writer_matched{0};
    ReaderCallbacks rc;
    rc.on_sample = [&](Sample&&) { ++received; };
    rc.on_matched = [&](const MatchStatus& s) { matched = s.current; };
    WriterCallbacks wc;
    wc.on_matched = [&](const MatchStatus& s) { writer_matched = s.current; };
    auto reader = (*b)->createReader("/chatter", "std_msgs/msg/String", *qosProfile("default"), rc);
    auto writer = (*a)->createWriter("/chatter", "std_msgs/msg/String", *qosProfile("default"), wc);
    ASSERT_TRUE(reader.ok() && writer.ok());
    // Both sides: a volatile writer that has not matched the reader yet sends it nothing.
    ASSERT_TRUE(eventually([&] { return matched > 0 && writer_matched > 0; }, 15000));
    // Two participants of one process: the sample crosses UDP (intra-process delivery off).
    ASSERT_TRUE((*a)->write(*writer, stringSample("in-process")).ok());
    EXPECT_TRUE(eventually([&] { return received > 0; }, 15000));
    // A Fast DDS log line starts its process-wide log thread (as an error of the library
    // would): the last participant's teardown stops it.
    EPROSIMA_LOG_ERROR(SKROBOT_TEST, "not an error: dds_core_test starts the log thread");
    EXPECT_GT(threadCount(), before);
    EXPECT_TRUE((*a)->deleteEndpoint(*writer).ok());
    EXPECT_FALSE((*a)->write(*writer, stringSample("gone")).ok());
  }
  EXPECT_EQ(threadCount(), before);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::string(argv[1]) == "--peer") return runPeer(argc, argv);
  if (const int failed = skr::test::enterOwnNetworkNamespace(argc, argv); failed != 0) {
    return failed;
  }
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
