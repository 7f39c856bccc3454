// SPDX-License-Identifier: Apache-2.0
// Config loading and validation: defaults, every kind of error, path resolution.
#include <skrobot/hub/config_edit.h>
#include <skrobot/hub/hub_config.h>
#include <skrobot/hub/json_schema.h>

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace skr {
namespace {

namespace fs = std::filesystem;

Result<HubConfig> parse(std::string_view text) {
  return parseHubConfig(text, "test.json", "/etc/robot");
}

// The error message of a document that must fail.
std::string errorOf(std::string_view text) {
  Result<HubConfig> r = parse(text);
  if (r.ok()) {
    ADD_FAILURE() << "expected an error for: " << text;
    return {};
  }
  EXPECT_EQ(r.error().code, Errc::config_error);
  return r.error().message;
}

#define EXPECT_HAS(haystack, needle) \
  EXPECT_NE((haystack).find(needle), std::string::npos) << (haystack)

TEST(ConfigTest, DefaultConfigLoads) {
  Result<HubConfig> r = loadHubConfig(fs::path(SKROBOT_SOURCE_DIR) / "config" / "default.json");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->app_name, "Robot");
  EXPECT_EQ(r->log_level, log::Level::info);
  EXPECT_EQ(r->loop.mode, TimingMode::coarse);
  EXPECT_EQ(r->loop.fast_interval_ns, 10 * kNsPerMs);
  EXPECT_EQ(r->loop.slow_interval_ns, 100 * kNsPerMs);
  EXPECT_EQ(r->loop.busy_poll_ns, Nanos{50000});
  // The web port (the network page, pages and Node.js satellites) on loopback, read-only pages.
  ASSERT_TRUE(r->server.web);
  EXPECT_EQ(r->server.web->address, "127.0.0.1");
  EXPECT_EQ(r->server.web->port, 8080);
  EXPECT_TRUE(r->server.web->flows);
  EXPECT_EQ(r->server.web->page_account, "web-page");
  // The avatar demo: the browser page, vision on the browser's camera, audio, speech, a Nao.
  std::vector<std::string> names;
  for (const ModuleEntry& m : r->modules) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"websocket-ui", "video-source", "video-mono",
                                             "face-detect", "motion", "qrcode", "fft-audio",
                                             "speech", "audio-io", "vorbis", "nao-bridge", "agent",
                                             "foxglove-bridge", "example"}));
  const ModuleEntry& ui = r->modules[0];
  EXPECT_TRUE(ui.enabled);
  EXPECT_FALSE(ui.own_thread);
  EXPECT_TRUE(ui.path.empty());
  EXPECT_EQ(ui.json_path, "$.modules[0]");
  EXPECT_FALSE(ui.config.isMember("port"));  // on the hub's web port
  EXPECT_EQ(r->modules[3].config["input"].asString(), "video-mono.mono");
  EXPECT_FALSE(r->modules[1].enabled);  // video-source: needs a camera or a file
  EXPECT_FALSE(r->modules.back().enabled);
  EXPECT_EQ(r->modules.back().config["period_ms"].asInt(), 1000);
  EXPECT_TRUE(r->config_file.is_absolute());
  EXPECT_EQ(r->config_file.filename(), "default.json");
}

// The example in the user documentation stays valid.
TEST(ConfigTest, DocumentedExampleLoads) {
  std::ifstream in(fs::path(SKROBOT_SOURCE_DIR) / "docs" / "config.md");
  const std::string md{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  const auto start = md.find("```json\n");
  ASSERT_NE(start, std::string::npos);
  const auto end = md.find("```", start + 8);
  Result<HubConfig> r = parse(md.substr(start + 8, end - start - 8));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->modules.size(), 3u);
  EXPECT_EQ(r->modules[1].name, "face-detect");
  EXPECT_EQ(r->modules[1].loop.mode, TimingMode::none);
}

TEST(ConfigTest, CommentsAreAccepted) {
  EXPECT_TRUE(parse("// the hub\n{ /* no modules yet */ \"modules\": [] }").ok());
}

TEST(ConfigTest, DefaultsFillIn) {
  Result<HubConfig> r = parse(R"({"modules": [{"name": "a"}]})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->app_name, "Robot");
  EXPECT_EQ(r->log_level, log::Level::info);
  EXPECT_EQ(r->loop.mode, TimingMode::coarse);
  EXPECT_EQ(r->loop.fast_interval_ns, 10 * kNsPerMs);
  EXPECT_EQ(r->loop.slow_interval_ns, 100 * kNsPerMs);
  EXPECT_EQ(r->loop.busy_poll_ns, Nanos{50000});
  EXPECT_DOUBLE_EQ(r->loop.load_warning_ratio, 0.8);
  EXPECT_TRUE(r->module_paths.empty());
  ASSERT_EQ(r->modules.size(), 1u);
  EXPECT_TRUE(r->modules[0].enabled);
  EXPECT_FALSE(r->modules[0].own_thread);
  EXPECT_TRUE(r->modules[0].config.isObject());
  EXPECT_TRUE(r->modules[0].config.empty());
  EXPECT_EQ(r->modules[0].loop.name, "a");
  EXPECT_EQ(r->modules[0].loop.fast_interval_ns, 10 * kNsPerMs);
  // raw keeps the document, defaults included, for sections read elsewhere.
  EXPECT_EQ(r->raw["loop"]["timing"].asString(), "coarse");
  EXPECT_EQ(r->raw["modules"][0]["name"].asString(), "a");
}

TEST(ConfigTest, ValuesAreRead) {
  Result<HubConfig> r = parse(R"({
    "app_name": "nao-1.lab_2",
    "log": {"level": "debug"},
    "loop": {"timing": "pseudo-realtime", "fast_tick_ms": 2.5, "slow_tick_ms": 50,
             "load_warning_ratio": 0.5},
    "modules": [
      {"name": "cam", "own_thread": true, "loop": {"timing": "none", "fast_tick_ms": 1},
       "config": {"fps": 30}},
      {"name": "off", "enabled": false}
    ]})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->app_name, "nao-1.lab_2");
  EXPECT_EQ(r->log_level, log::Level::debug);
  EXPECT_EQ(r->loop.mode, TimingMode::pseudo_realtime);
  EXPECT_EQ(r->loop.fast_interval_ns, 2'500'000);
  EXPECT_EQ(r->loop.slow_interval_ns, 50 * kNsPerMs);
  EXPECT_DOUBLE_EQ(r->loop.load_warning_ratio, 0.5);
  ASSERT_EQ(r->modules.size(), 2u);
  const ModuleEntry& cam = r->modules[0];
  EXPECT_TRUE(cam.own_thread);
  EXPECT_EQ(cam.loop.name, "cam");
  EXPECT_EQ(cam.loop.mode, TimingMode::none);
  EXPECT_EQ(cam.loop.fast_interval_ns, 1 * kNsPerMs);
  EXPECT_EQ(cam.loop.slow_interval_ns, 50 * kNsPerMs);  // inherited
  EXPECT_DOUBLE_EQ(cam.loop.load_warning_ratio, 0.5);   // inherited
  EXPECT_EQ(cam.config["fps"].asInt(), 30);
  EXPECT_FALSE(r->modules[1].enabled);
}

TEST(ConfigTest, TlsSettingsAreReadAndResolved) {
  Result<HubConfig> r = parse(R"({"server": {"tcp": true, "tcp_address": "0.0.0.0",
    "tls": {"cert": "tls/hub.pem", "key": "/keys/hub.key", "client_ca": "ca.pem"}}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE(r->server.tls.has_value());
  EXPECT_EQ(r->server.tls->cert_file, "/etc/robot/tls/hub.pem");
  EXPECT_EQ(r->server.tls->key_file, "/keys/hub.key");
  EXPECT_EQ(r->server.tls->ca_file, "/etc/robot/ca.pem");
  EXPECT_EQ(r->server.tls->min_version, "1.2");
  auto plain = parse(R"({"server": {"tcp": true}})");
  ASSERT_TRUE(plain.ok());
  EXPECT_FALSE(plain->server.tls.has_value());
  auto no_ca = parse(R"({"server": {"tcp": true, "tls": {"cert": "a", "key": "b",
                          "min_version": "1.3"}}})");
  ASSERT_TRUE(no_ca.ok()) << no_ca.error().message;
  EXPECT_EQ(no_ca->server.tls->ca_file, "");
  EXPECT_EQ(no_ca->server.tls->min_version, "1.3");

  EXPECT_HAS(errorOf(R"({"server": {"tls": {"cert": "a", "key": "b"}}})"),
             "$.server.tls: TLS is served on the TCP listener and the web port: set \"tcp\": "
             "true or \"web\"");
  // The web port alone may speak TLS.
  auto web_tls = parse(R"({"server": {"web": {}, "tls": {"cert": "a", "key": "b"}}})");
  EXPECT_TRUE(web_tls.ok()) << web_tls.error().message;
  EXPECT_HAS(errorOf(R"({"server": {"tcp": true, "tls": {"cert": "a"}}})"), "key");
  EXPECT_HAS(errorOf(R"({"server": {"tcp": true, "tls": {"cert": "a", "key": "b",
                          "min_version": "1.1"}}})"),
             "min_version");
}

TEST(ConfigTest, SyntaxErrorHasLineAndColumn) {
  std::string msg = errorOf("{\n  \"app_name\": \"x\",\n  \"log\" {}\n}");
  EXPECT_HAS(msg, "test.json:3:9: Missing ':'");
  msg = errorOf(R"({"app_name": "a", "app_name": "b"})");
  EXPECT_HAS(msg, "test.json:1:");
  EXPECT_HAS(msg, "Duplicate key: 'app_name'");
  EXPECT_HAS(errorOf(""), "test.json:1:1: ");
  EXPECT_HAS(errorOf("{} {}"), "Extra non-whitespace");
}

TEST(ConfigTest, UnknownKeyWithSuggestion) {
  std::string msg = errorOf(R"({"loop": {"fast_tik_ms": 5}})");
  EXPECT_EQ(msg, R"(test.json: $.loop: unknown key "fast_tik_ms" (did you mean "fast_tick_ms"?))");
  msg = errorOf(R"({"network": {}})");
  EXPECT_EQ(msg, R"(test.json: $: unknown key "network")");
  msg = errorOf(R"({"modules": [{"name": "a", "enable": false}]})");
  EXPECT_EQ(msg, R"(test.json: $.modules[0]: unknown key "enable" (did you mean "enabled"?))");
}

TEST(ConfigTest, WrongType) {
  EXPECT_EQ(errorOf(R"({"modules": [{"name": "a"}, {"name": "b", "enabled": "yes"}]})"),
            "test.json: $.modules[1].enabled: expected boolean, got string");
  EXPECT_EQ(errorOf(R"({"loop": {"fast_tick_ms": "10"}})"),
            "test.json: $.loop.fast_tick_ms: expected number, got string");
  EXPECT_EQ(errorOf(R"({"modules": {"name": "a"}})"),
            "test.json: $.modules: expected array, got object");
  EXPECT_EQ(errorOf(R"({"modules": [{"name": "a", "config": []}]})"),
            "test.json: $.modules[0].config: expected object, got array");
  EXPECT_EQ(errorOf("[]"), "test.json: $: expected object, got array");
}

TEST(ConfigTest, SerialPortsAreReadAndCheckedByPath) {
  Result<HubConfig> r = parse(R"({"server": {"serial": [{"device": "/dev/ttyUSB*"},
      {"device": "/dev/ttyACM0", "baud": 1000000, "account": "arm", "max_frame": 256}]}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->server.serial.size(), 2u);
  EXPECT_EQ(r->server.serial[0].device, "/dev/ttyUSB*");
  EXPECT_EQ(r->server.serial[0].baud, 115200u);
  EXPECT_EQ(r->server.serial[0].max_frame, 4096u);
  EXPECT_EQ(r->server.serial[1].baud, 1000000u);
  EXPECT_EQ(r->server.serial[1].account, "arm");
  EXPECT_EQ(r->server.serial[1].max_frame, 256u);
  EXPECT_EQ(errorOf(R"({"server": {"serial": [{"device": "ttyUSB0"}]}})"),
            "test.json: $.server.serial[0].device: must be an absolute path (/dev/...)");
  EXPECT_HAS(errorOf(R"({"server": {"serial": [{"device": "/dev/ttyS0", "baud": 9}]}})"),
             "$.server.serial[0].baud");
}

TEST(ConfigTest, TheUdpPortIsOffUnlessSetAndNeedsANumericAddress) {
  Result<HubConfig> r = parse(R"({"server": {}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->server.udp);
  r = parse(R"({"server": {"udp": {"address": "0.0.0.0"}}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE(r->server.udp);
  EXPECT_EQ(r->server.udp->port, 9001);
  EXPECT_EQ(r->server.udp->max_datagram, 1200u);
  EXPECT_EQ(r->server.udp->session_timeout_ms, 10000u);
  r = parse(R"({"server": {"udp": {"address": "::1", "port": 9100, "max_datagram": 512,
      "session_timeout_ms": 3000}}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->server.udp->address, "::1");
  EXPECT_EQ(r->server.udp->port, 9100);
  EXPECT_EQ(r->server.udp->max_datagram, 512u);
  EXPECT_EQ(r->server.udp->session_timeout_ms, 3000u);
  EXPECT_HAS(errorOf(R"({"server": {"udp": {}}})"), "$.server.udp.address");
  EXPECT_EQ(errorOf(R"({"server": {"udp": {"address": "localhost"}}})"),
            "test.json: $.server.udp.address: must be a numeric IPv4 or IPv6 address (127.0.0.1, "
            "0.0.0.0, ::)");
  EXPECT_HAS(errorOf(R"({"server": {"udp": {"address": "0.0.0.0", "max_datagram": 64}}})"),
             "$.server.udp.max_datagram");
}

TEST(ConfigTest, TheWebPortIsOffUnlessSetAndLoopbackByDefault) {
  Result<HubConfig> r = parse(R"({"server": {}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->server.web);
  r = parse(R"({"server": {"web": {}}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE(r->server.web);
  const flow::WebOptions& d = *r->server.web;
  EXPECT_EQ(d.address, "127.0.0.1");
  EXPECT_EQ(d.port, 8080);
  EXPECT_TRUE(d.root.empty());  // the installed page
  EXPECT_TRUE(d.mounts.empty());
  EXPECT_FALSE(d.flows);
  EXPECT_TRUE(d.origins.empty());
  EXPECT_TRUE(d.hosts.empty());
  EXPECT_EQ(d.page_account, "web-page");
  EXPECT_EQ(d.token_ttl_ms, 60000u);
  EXPECT_FALSE(d.dev_account);

  r = parse(R"({"accounts": {"dev_account": {"user": "guest", "password": "pw"}},
      "server": {"web": {"address": "0.0.0.0", "port": 8443, "root": "site",
      "mounts": {"/teleop": "examples/teleop", "/skrobot": "/usr/share/skrobot/js"},
      "flows": true, "origins": ["https://robot.local:8443"], "hosts": ["robot.local"],
      "page_account": "teleop", "token_ttl_ms": 1000, "dev_account": true}}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const flow::WebOptions& w = *r->server.web;
  EXPECT_EQ(w.address, "0.0.0.0");
  EXPECT_EQ(w.port, 8443);
  EXPECT_EQ(w.root, "/etc/robot/site");
  ASSERT_EQ(w.mounts.size(), 2u);
  EXPECT_EQ(w.mounts[0].first, "/skrobot");  // jsoncpp lists members sorted
  EXPECT_EQ(w.mounts[0].second, "/usr/share/skrobot/js");
  EXPECT_EQ(w.mounts[1].first, "/teleop");
  EXPECT_EQ(w.mounts[1].second, "/etc/robot/examples/teleop");
  EXPECT_TRUE(w.flows);
  EXPECT_EQ(w.origins, std::vector<std::string>{"https://robot.local:8443"});
  EXPECT_EQ(w.hosts, std::vector<std::string>{"robot.local"});
  EXPECT_EQ(w.page_account, "teleop");
  EXPECT_EQ(w.token_ttl_ms, 1000u);
  EXPECT_TRUE(w.dev_account);

  // Each bad key names its path and why.
  EXPECT_EQ(errorOf(R"({"server": {"web": {"mounts": {"/a/../b": "x"}}}})"),
            "test.json: $.server.web.mounts[\"/a/../b\"]: must be a URL path prefix: '/' then "
            "segments of letters, digits, '_', '.', '-', '~' (not \".\" or \"..\"), no trailing "
            "'/' (\"/teleop\")");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"mounts": {"/": "x"}}}})"), "$.server.web.mounts");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"mounts": {"/t/": "x"}}}})"), "URL path prefix");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"mounts": {"/t": ""}}}})"),
             "$.server.web.mounts[\"/t\"]: must be a directory");
  EXPECT_EQ(errorOf(R"({"server": {"web": {"mounts": {"/flow": "x"}}}})"),
            "test.json: $.server.web.mounts[\"/flow\"]: is answered by the web port itself and "
            "cannot be a mount");
  EXPECT_EQ(errorOf(R"({"server": {"web": {"origins": ["https://robot.local/page"]}}})"),
            "test.json: $.server.web.origins[0]: must be an origin as browsers send it, lower "
            "case: \"http://host[:port]\" or \"https://host[:port]\", got "
            "\"https://robot.local/page\"");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"origins": ["ws://robot.local"]}}})"),
             "$.server.web.origins[0]");
  EXPECT_EQ(errorOf(R"({"server": {"web": {"hosts": ["robot.local:8080"]}}})"),
            "test.json: $.server.web.hosts[0]: must be a lower-case host name without a port "
            "(\"robot.local\"), got \"robot.local:8080\"");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"port": 70000}}})"), "$.server.web.port");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"token_ttl_ms": 10}}})"), "$.server.web.token_ttl_ms");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"page_account": ""}}})"), "$.server.web.page_account");
  EXPECT_HAS(errorOf(R"({"server": {"web": {"flow": true}}})"),
             "unknown key \"flow\" (did you mean \"flows\"?)");
  EXPECT_EQ(errorOf(R"({"server": {"web": {"dev_account": true}}})"),
            "test.json: $.server.web.dev_account: lets the development account in over WebSocket "
            "from this machine, but $.accounts.dev_account sets none");
}

TEST(ConfigTest, OutOfRange) {
  EXPECT_EQ(errorOf(R"({"loop": {"fast_tick_ms": 0}})"),
            "test.json: $.loop.fast_tick_ms: must be >= 0.1, got 0");
  EXPECT_EQ(errorOf(R"({"loop": {"load_warning_ratio": 2}})"),
            "test.json: $.loop.load_warning_ratio: must be <= 1, got 2");
  // An out-of-range fast tick is reported once, not again by the slow >= fast check.
  EXPECT_EQ(errorOf(R"({"loop": {"fast_tick_ms": 5000}})"),
            "test.json: $.loop.fast_tick_ms: must be <= 1000, got 5000");
}

TEST(ConfigTest, BadEnumValue) {
  EXPECT_EQ(errorOf(R"({"loop": {"timing": "fast"}})"),
            R"(test.json: $.loop.timing: must be one of "coarse", "pseudo-realtime", )"
            R"("socket-driven", "none", got "fast")");
  EXPECT_EQ(
      errorOf(R"({"log": {"level": "verbose"}})"),
      R"(test.json: $.log.level: must be one of "debug", "info", "warn", "error", got "verbose")");
}

TEST(ConfigTest, SlowTickBelowFastTick) {
  EXPECT_EQ(errorOf(R"({"loop": {"fast_tick_ms": 50, "slow_tick_ms": 20}})"),
            "test.json: $.loop.slow_tick_ms: must be >= fast_tick_ms (50), got 20");
  EXPECT_EQ(errorOf(R"({"loop": {"fast_tick_ms": 200}})"),
            "test.json: $.loop.slow_tick_ms: must be >= fast_tick_ms (200), got 100 (the default)");
  EXPECT_EQ(errorOf(R"({"modules": [{"name": "a", "own_thread": true,
                                      "loop": {"slow_tick_ms": 5}}]})"),
            "test.json: $.modules[0].loop.slow_tick_ms: must be >= fast_tick_ms "
            "(10, inherited from $.loop), got 5");
}

TEST(ConfigTest, ModuleNeedsNameOrPath) {
  EXPECT_EQ(errorOf(R"({"modules": [{"enabled": true}]})"),
            R"(test.json: $.modules[0]: needs "name" (found on the module search path) or "path")");
}

TEST(ConfigTest, ModuleLoopNeedsOwnThread) {
  EXPECT_EQ(errorOf(R"({"modules": [{"name": "a", "loop": {"fast_tick_ms": 1}}]})"),
            R"(test.json: $.modules[0].loop: applies only to a module with "own_thread": true)");
}

TEST(ConfigTest, DuplicateEnabledModuleNames) {
  const std::string msg = errorOf(R"({"modules": [
      {"path": "a/libcam.so"}, {"name": "other"}, {"name": "cam", "path": "/opt/cam.so"}]})");
  EXPECT_EQ(msg,
            "test.json: $.modules[2]: duplicate module name \"cam\": $.modules[0] "
            "(/etc/robot/a/libcam.so) and $.modules[2] (/opt/cam.so) are both enabled");
  // A disabled duplicate is fine: it is how one keeps an alternative at hand.
  EXPECT_TRUE(parse(R"({"modules": [{"name": "cam"}, {"name": "cam", "enabled": false}]})").ok());
}

TEST(ConfigTest, SatellitesAreReadWithTheirDefaultsAndPathsResolved) {
  Result<HubConfig> r = parse(R"({"satellites": [
      {"name": "asr", "command": ["skrobot-asr", "--name", "asr"], "account": "guest",
       "ready": "login"},
      {"name": "drive", "command": ["bin/drive.py"], "after": ["asr", "base.odom"],
       "env": {"A": "1"}, "cwd": "run", "restart": "always", "stop_signal": "SIGINT",
       "limits": {"memory_mib": 64, "open_files": 100, "nice": 3}}]})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->satellites.size(), 2u);
  const SatelliteEntry& asr = r->satellites[0];
  EXPECT_EQ(asr.command[0], "skrobot-asr");  // looked up in PATH at start
  EXPECT_EQ(asr.cwd, "/etc/robot");
  EXPECT_EQ(asr.restart, SatelliteEntry::Restart::on_failure);
  EXPECT_EQ(asr.ready, "login");
  EXPECT_EQ(asr.stop_signal, 15);
  EXPECT_EQ(asr.grace_ms, 5000u);
  EXPECT_EQ(asr.backoff_ms, 1000u);
  EXPECT_EQ(asr.max_restarts_per_minute, 5u);
  const SatelliteEntry& drive = r->satellites[1];
  EXPECT_EQ(drive.command[0], "/etc/robot/bin/drive.py");
  EXPECT_EQ(drive.cwd, "/etc/robot/run");
  EXPECT_EQ(drive.ready, "started");
  EXPECT_EQ(drive.stop_signal, 2);
  EXPECT_EQ(drive.memory_bytes, 64u << 20);
  EXPECT_EQ(drive.open_files, 100u);
  EXPECT_EQ(drive.nice, 3);
  EXPECT_EQ(drive.after, (std::vector<std::string>{"asr", "base.odom"}));
  EXPECT_EQ(drive.env, (std::vector<std::pair<std::string, std::string>>{{"A", "1"}}));
}

TEST(ConfigTest, BadSatellitesAreReportedWithTheirPaths) {
  const std::string msg = errorOf(R"({"satellites": [
      {"name": "a", "command": ["x"], "after": ["b"]},
      {"name": "b", "command": ["x"], "after": ["a", "nobody"], "ready": "soon"},
      {"name": "a", "command": [], "env": {"ROBOT_PASSWORD": "x"}, "restart": "sometimes"},
      {"name": "c d", "command": ["x"], "after": ["c d"]}]})");
  EXPECT_HAS(msg, "$.satellites[0].after: a circle: a -> b -> a (each waits for the other)");
  EXPECT_HAS(msg, "$.satellites[1].after: no satellite nobody (a channel's name has a '.')");
  EXPECT_HAS(msg, R"($.satellites[1].ready: expected "started", "login" or a channel's name)");
  EXPECT_HAS(msg, "$.satellites[2].command: must have at least 1 items");
  EXPECT_HAS(msg, "$.satellites[2].restart:");
  EXPECT_HAS(msg, "$.satellites[3].name: may contain only letters, digits, '_' and '-'");
}

TEST(ConfigEditTest, OnlyTheChangedValuesOfAModulesConfigAreWritten) {
  const std::string text = R"(// the robot
{ "modules": [ {"name": "a"},
    { "name": "b", "config": { "greeting": "one", /* why */ "period_ms": 10 } },
    { "name": "c", "config": {} } ],
  "satellites": [ {"name": "s", "command": ["x"]} ] })";
  Json::Value v;
  v["greeting"] = "two";
  v["extra"] = true;
  auto b = editModuleConfig(text, 1, v);
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_EQ(*b, R"(// the robot
{ "modules": [ {"name": "a"},
    { "name": "b", "config": {"extra": true,  "greeting": "two", /* why */ "period_ms": 10 } },
    { "name": "c", "config": {} } ],
  "satellites": [ {"name": "s", "command": ["x"]} ] })");
  Json::Value p;
  p["period_ms"] = 20;
  auto a = editModuleConfig(text, 0, p);  // no config object yet
  ASSERT_TRUE(a.ok());
  EXPECT_NE(a->find(R"({ "config": {"period_ms": 20}, "name": "a"})"), std::string::npos) << *a;
  auto c = editModuleConfig(text, 2, p);  // an empty one
  ASSERT_TRUE(c.ok());
  EXPECT_NE(c->find(R"("config": {"period_ms": 20})"), std::string::npos) << *c;
  EXPECT_FALSE(editModuleConfig(text, 3, p).ok());
  EXPECT_FALSE(editModuleConfig("{", 0, p).ok());
}

TEST(ConfigTest, AppNameMustNameASocketFile) {
  EXPECT_EQ(errorOf(R"({"app_name": ""})"), "test.json: $.app_name: must not be empty");
  EXPECT_HAS(errorOf(R"({"app_name": "my robot"})"),
             "test.json: $.app_name: may contain only letters, digits, '_', '.' and '-'");
  EXPECT_HAS(errorOf(R"({"app_name": "../x"})"), "$.app_name: may contain only");
  EXPECT_EQ(errorOf(R"({"app_name": ".."})"), R"(test.json: $.app_name: must not be "." or "..")");
  EXPECT_HAS(errorOf("{\"app_name\": \"" + std::string(101, 'a') + "\"}"), "at most 100");
}

TEST(ConfigTest, RelativePathsResolveAgainstConfigDir) {
  Result<HubConfig> r = parse(R"({"module_paths": ["mods", "../lib/skrobot", "/usr/lib/sk"],
                                  "modules": [{"path": "build/libcamera.so"},
                                              {"path": "/opt/motion.so.1"}]})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->module_paths.size(), 3u);
  EXPECT_EQ(r->module_paths[0], "/etc/robot/mods");
  EXPECT_EQ(r->module_paths[1], "/etc/lib/skrobot");
  EXPECT_EQ(r->module_paths[2], "/usr/lib/sk");
  EXPECT_EQ(r->modules[0].path, "/etc/robot/build/libcamera.so");
  EXPECT_EQ(r->modules[0].name, "camera");
  EXPECT_EQ(r->modules[1].path, "/opt/motion.so.1");
  EXPECT_EQ(r->modules[1].name, "motion");
  EXPECT_EQ(errorOf(R"({"modules": [{"path": "mods/"}]})"),
            "test.json: $.modules[0].path: names no file");
}

TEST(ConfigTest, LoadResolvesAgainstTheFilesDirectory) {
  const fs::path dir = fs::temp_directory_path() / ("skrobot-config-" + std::to_string(getpid()));
  fs::create_directories(dir / "sub");
  const fs::path file = dir / "sub" / "hub.json";
  std::ofstream(file) << R"({"modules": [{"path": "../mods/x.so"}]})";
  Result<HubConfig> r = loadHubConfig(file);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->config_file, file);
  EXPECT_EQ(r->modules[0].path, dir / "mods" / "x.so");

  std::ofstream(file) << R"({"log": {"level": 3}})";
  r = loadHubConfig(file);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, file.string() + ": $.log.level: expected string, got integer");

  EXPECT_EQ(loadHubConfig(dir).error().code, Errc::io_error);  // a directory
  fs::remove_all(dir);

  r = loadHubConfig(dir / "missing.json");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::not_found);
}

TEST(ConfigTest, EveryProblemIsReportedAtOnce) {
  const std::string msg = errorOf(R"({
    "app_name": "a b",
    "loop": {"fast_tik_ms": 5, "timing": "socket"},
    "modules": [{"name": "m", "enabled": 1}, {"own_thread": false}],
    "extra": true})");
  EXPECT_EQ(
      msg,
      "test.json: $.app_name: may contain only letters, digits, '_', '.' and '-' (it names "
      "the socket /tmp/<app_name>), got \"a b\"\n"
      "test.json: $.loop.timing: must be one of \"coarse\", \"pseudo-realtime\", "
      "\"socket-driven\", \"none\", got \"socket\"\n"
      "test.json: $.loop: unknown key \"fast_tik_ms\" (did you mean \"fast_tick_ms\"?)\n"
      "test.json: $.modules[0].enabled: expected boolean, got integer\n"
      "test.json: $.modules[1]: needs \"name\" (found on the module search path) or \"path\"\n"
      "test.json: $: unknown key \"extra\"");
}

TEST(ConfigTest, HubLinksAreReadWithTheirPasswordsFromOutsideTheConfig) {
  const fs::path dir = fs::temp_directory_path() / ("skrobot-links-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path pass = dir / "arm.pass";
  std::ofstream(pass) << "s3cret\nignored\n";
  fs::permissions(pass, fs::perms::owner_read | fs::perms::owner_write);
  ::setenv("SKROBOT_TEST_LINK_PW", "from-env", 1);
  const std::string ok = R"({"hub_name": "head", "links": [
      {"name": "arm", "address": "local:/tmp/Arm", "user": "link", "password_file": ")" +
                         pass.string() + R"("},
      {"name": "base", "address": "tls:base.lab:9100", "user": "link",
       "password_env": "SKROBOT_TEST_LINK_PW", "max_channels": 10,
       "tls": {"ca_file": "ca.pem"}}]})";
  Result<HubConfig> r = parse(ok);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->hub_name, "head");
  ASSERT_EQ(r->links.size(), 2u);
  EXPECT_EQ(r->links[0].password, "s3cret");
  EXPECT_EQ(r->links[0].max_channels, 4096u);
  EXPECT_EQ(r->links[1].password, "from-env");
  EXPECT_EQ(r->links[1].max_channels, 10u);
  EXPECT_EQ(r->links[1].tls.ca_file, "/etc/robot/ca.pem");

  // A password file others may read, a password in the config, TCP off the machine, a name
  // twice, this hub's own name, a bad hub name, no password, an unset variable.
  fs::permissions(pass, fs::perms::group_read, fs::perm_options::add);
  const std::string msg = errorOf(R"({"hub_name": "head", "links": [
      {"name": "arm", "address": "local:/tmp/Arm", "user": "l", "password_file": ")" +
                                  pass.string() + R"("},
      {"name": "arm", "address": "tcp:10.0.0.2:9000", "user": "l", "password": "x"},
      {"name": "head", "address": "tcp:127.0.0.1:9000", "user": "l", "password_env": "NOPE_X"},
      {"name": "a.b", "address": "local:/tmp/x", "user": "l", "password_file": "x",
       "password_env": "Y"}]})");
  EXPECT_HAS(msg, "$.links[0].password_file: " + pass.string() + " may be read by others");
  EXPECT_HAS(msg, "$.links[1]: unknown key \"password\"");
  EXPECT_HAS(msg, "$.links[1].name: hub arm is linked twice");
  EXPECT_HAS(msg, "$.links[1].address: a link over TCP to another machine needs TLS");
  EXPECT_HAS(msg, "$.links[1]: needs one of \"password_file\" and \"password_env\"");
  EXPECT_HAS(msg, "$.links[2].name: is this hub's own hub_name");
  EXPECT_HAS(msg, "$.links[2].password_env: the variable NOPE_X is not set");
  EXPECT_HAS(msg, "$.links[3].name: a hub name is 1 to 64 of A-Z a-z 0-9 _ -, got \"a.b\"");
  EXPECT_HAS(msg, "$.links[3]: needs one of");
  EXPECT_HAS(errorOf(R"({"hub_name": "no/slash"})"), "$.hub_name: a hub name is 1 to 64");
  fs::remove_all(dir);
}

// The schema on its own, for the parts the hub's config does not exercise.
TEST(JsonSchemaTest, RequiredIntegerAndArrayBounds) {
  namespace s = schema;
  const s::Schema server = s::object({
      s::required("port", s::integer().range(1, 65535)),
      s::optional("hosts", s::arrayOf(s::string()).items(1, 2)),
      s::optional("extra", s::anyObject()),
  });
  Json::Value v(Json::objectValue);
  v["hosts"] = Json::Value(Json::arrayValue);
  s::Problems p = s::validate(v, server, "$.server");
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].path, "$.server.port");
  EXPECT_EQ(p[0].reason, "required key missing");
  EXPECT_EQ(p[1].path, "$.server.hosts");
  EXPECT_EQ(p[1].reason, "must have at least 1 items, got 0");

  v["port"] = 1.5;
  p = s::validate(v, server.allowUnknownKeys(), "$");
  ASSERT_FALSE(p.empty());
  EXPECT_EQ(p[0].reason, "expected integer, got non-integral number");
  v["port"] = 8080.0;  // integral, written with a decimal point
  v["hosts"].append("a");
  v["whatever"] = 1;
  EXPECT_TRUE(s::validate(v, server.allowUnknownKeys()).empty());
}

TEST(JsonSchemaTest, WithDefaultsFillsNestedSections) {
  namespace s = schema;
  const s::Schema doc = s::object({
      s::optional("net", s::object({s::optional("port", s::integer(), 7000)}), Json::objectValue),
      s::optional("items", s::arrayOf(s::object({s::optional("on", s::boolean(), true)}))),
      s::optional("absent", s::string()),
  });
  Json::Value v(Json::objectValue);
  v["items"].append(Json::Value(Json::objectValue));
  const Json::Value filled = s::withDefaults(v, doc);
  EXPECT_EQ(filled["net"]["port"].asInt(), 7000);
  EXPECT_TRUE(filled["items"][0]["on"].asBool());
  EXPECT_FALSE(filled.isMember("absent"));
  EXPECT_EQ(s::childPath("$", "a key"), R"($["a key"])");
  EXPECT_EQ(s::indexPath("$.m", 3), "$.m[3]");
}

}  // namespace
}  // namespace skr
