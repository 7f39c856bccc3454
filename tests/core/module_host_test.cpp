// SPDX-License-Identifier: Apache-2.0
// The module host through its public interface, with the example module and the test modules
// of tests/modules (one per failure case). No assertion depends on timing: loops run until a
// condition holds, with generous time limits.
#include <skrobot/hub/module_host.h>
#include <skrobot/plugin.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <pthread.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

namespace skr {
namespace {

namespace fs = std::filesystem;

constexpr Nanos kTimeout = 30 * kNsPerSec;
constexpr const char* kModuleDir = SKROBOT_MODULE_DIR;
constexpr const char* kTestModuleDir = SKROBOT_TEST_MODULE_DIR;

struct Line {
  log::Level level;
  std::string source, tag, message;
};

// Every log line while alive; any thread.
class Capture {
 public:
  Capture() { log::setHook(&Capture::hook, this); }
  ~Capture() { log::setHook(nullptr, nullptr); }
  Capture(const Capture&) = delete;
  Capture& operator=(const Capture&) = delete;
  Capture(Capture&&) = delete;
  Capture& operator=(Capture&&) = delete;

  std::vector<Line> withTag(const std::string& tag) const {
    std::lock_guard lock(mutex_);
    std::vector<Line> out;
    for (const auto& l : lines_) {
      if (l.tag == tag) out.push_back(l);
    }
    return out;
  }
  size_t count(const std::string& tag) const { return withTag(tag).size(); }
  // Sources of the lines with `tag`, in order.
  std::vector<std::string> messages(const std::string& tag) const {
    std::vector<std::string> out;
    for (const auto& l : withTag(tag)) out.push_back(l.message);
    return out;
  }

 private:
  static void hook(log::Level level, std::string_view source, std::string_view tag,
                   std::string_view message, void* user) {
    auto* self = static_cast<Capture*>(user);
    std::lock_guard lock(self->mutex_);
    self->lines_.push_back(
        Line{level, std::string(source), std::string(tag), std::string(message)});
  }
  mutable std::mutex mutex_;
  std::vector<Line> lines_;
};

ModuleEntry entry(const fs::path& file, Json::Value config = Json::Value(Json::objectValue)) {
  ModuleEntry e;
  e.name = file.stem().string();
  e.path = file;
  e.config = std::move(config);
  return e;
}

fs::path testModule(const std::string& name) {
  return fs::path(kTestModuleDir) / (name + ".so");
}
fs::path exampleModule() {
  return fs::path(kModuleDir) / "example.so";
}

Json::Value exampleConfig(const std::string& greeting, int period_ms) {
  Json::Value c(Json::objectValue);
  c["greeting"] = greeting;
  c["period_ms"] = period_ms;
  return c;
}

// A counter exported by a loaded test module (the host keeps the library open).
int counter(const fs::path& file, const char* symbol) {
  void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (handle == nullptr) return -1;
  auto fn = reinterpret_cast<int (*)()>(dlsym(handle, symbol));
  const int value = fn != nullptr ? fn() : -1;
  dlclose(handle);
  return value;
}

const ModuleFailure* failureOf(const ModuleHost& host, const std::string& name) {
  for (const auto& f : host.failures()) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

std::string threadId() {
  return std::to_string(static_cast<std::uint64_t>(pthread_self()));
}

class ModuleHostTest : public ::testing::Test {
 protected:
  void SetUp() override { unsetenv("SKROBOT_MODULE_PATH"); }

  // Runs the main loop until `done` or the (generous) time limit.
  bool runUntil(const std::function<bool()>& done) { return loop.runUntil(done, kTimeout); }
  // Runs the main loop for `n` more fast ticks.
  void runTicks(std::uint64_t n) {
    const auto target = loop.stats().fast_ticks + n;
    ASSERT_TRUE(runUntil([&] { return loop.stats().fast_ticks >= target; }));
  }

  Capture capture;
  Loop loop{[] {
    LoopOptions o;
    o.fast_interval_ns = 2 * kNsPerMs;
    o.slow_interval_ns = 4 * kNsPerMs;
    return o;
  }()};
};

TEST_F(ModuleHostTest, ExampleRunsItsWholeLifecycle) {
  ModuleHost host(loop, {});
  host.start({entry(exampleModule(), exampleConfig("hi", 5))});
  ASSERT_TRUE(host.failures().empty());
  ASSERT_EQ(host.modules().size(), 1u);
  EXPECT_EQ(host.modules()[0].state, ModuleState::started);
  EXPECT_EQ(host.modules()[0].module_name, "example");
  EXPECT_EQ(host.modules()[0].version, "1.0.0");
  EXPECT_EQ(capture.count("EXAMPLE-START"), 1u);

  // Ticks every period_ms, and results computed on the worker come back through post().
  ASSERT_TRUE(runUntil(
      [&] { return capture.count("EXAMPLE-TICK") >= 3 && capture.count("EXAMPLE-WORK") >= 2; }));
  const auto ticks = capture.withTag("EXAMPLE-TICK");
  EXPECT_EQ(ticks[0].source, "mod.example");
  EXPECT_EQ(ticks[0].message, "hi #1");
  EXPECT_EQ(ticks[1].message, "hi #2");

  host.shutdown();
  EXPECT_EQ(capture.count("EXAMPLE-STOP"), 1u);
  EXPECT_EQ(host.modules()[0].state, ModuleState::unloaded);
  EXPECT_TRUE(host.failures().empty());
  // Nothing of the module is left on the loop: it keeps running without it.
  const auto after = capture.count("EXAMPLE-TICK");
  runTicks(20);
  EXPECT_EQ(capture.count("EXAMPLE-TICK"), after);
}

TEST_F(ModuleHostTest, FindsModulesByNameNextToTheExecutable) {
  ModuleHost host(loop, {});
  ModuleEntry e;
  e.name = "example";
  host.load({e});
  ASSERT_EQ(host.modules().size(), 1u);
  EXPECT_TRUE(fs::equivalent(host.modules()[0].file, exampleModule()));
  EXPECT_EQ(host.modules()[0].state, ModuleState::loaded);
}

TEST_F(ModuleHostTest, ConfigPathsComeFirst) {
  setenv("SKROBOT_MODULE_PATH", "/nonexistent/e1::/nonexistent/e2", 1);
  const auto dirs = moduleSearchPath({"/nonexistent/c"});
  ASSERT_EQ(dirs.size(), 5u);
  EXPECT_EQ(dirs[0], "/nonexistent/c");
  EXPECT_EQ(dirs[1], "/nonexistent/e1");
  EXPECT_EQ(dirs[2], "/nonexistent/e2");
  EXPECT_TRUE(fs::equivalent(dirs[3], kModuleDir));  // tests run from <build>/bin
  EXPECT_EQ(dirs[4].filename(), "modules");
  EXPECT_EQ(dirs[4].parent_path().filename(), "skrobot");
}

TEST_F(ModuleHostTest, MissingModuleSaysWhereItLooked) {
  setenv("SKROBOT_MODULE_PATH", "/nonexistent/env", 1);
  ModuleHost host(loop, {"/nonexistent/config"});
  ModuleEntry by_name;
  by_name.name = "does_not_exist";
  host.start({by_name, entry("/nonexistent/file/gone.so")});
  ASSERT_EQ(host.failures().size(), 2u);
  const auto& f = host.failures()[0];
  EXPECT_EQ(f.name, "does_not_exist");
  EXPECT_EQ(f.tag, "MODULE-NOT-FOUND");
  EXPECT_NE(f.reason.find("does_not_exist.so"), std::string::npos) << f.reason;
  for (const auto& dir : host.searchPath()) {
    EXPECT_NE(f.reason.find(dir.string()), std::string::npos) << dir << " in " << f.reason;
  }
  EXPECT_NE(f.reason.find("/nonexistent/config"), std::string::npos);
  EXPECT_NE(f.reason.find("/nonexistent/env"), std::string::npos);
  EXPECT_EQ(host.failures()[1].tag, "MODULE-NOT-FOUND");
  EXPECT_NE(host.failures()[1].reason.find("/nonexistent/file/gone.so"), std::string::npos);
  EXPECT_EQ(capture.count("MODULE-NOT-FOUND"), 2u);
}

TEST_F(ModuleHostTest, DisabledEntriesAreSkipped) {
  ModuleHost host(loop, {});
  auto e = entry(exampleModule());
  e.enabled = false;
  host.start({e});
  EXPECT_TRUE(host.modules().empty());
  EXPECT_TRUE(host.failures().empty());
  EXPECT_EQ(capture.count("MODULE-DISABLED"), 1u);
}

// One bad module among good ones: reported once by name, with the right tag and reason, and the
// good modules run anyway.
struct BadCase {
  const char* module;
  const char* tag;
  std::vector<std::string> reason_has;
};

void PrintTo(const BadCase& c, std::ostream* os) {
  *os << c.module;
}

class BadModule : public ModuleHostTest, public ::testing::WithParamInterface<BadCase> {};

TEST_P(BadModule, IsReportedAndTheOthersRun) {
  const BadCase& c = GetParam();
  ModuleHost host(loop, {});
  host.start({entry(testModule("test_plain_c")), entry(testModule(c.module)),
              entry(exampleModule(), exampleConfig("still here", 5))});

  ASSERT_EQ(host.failures().size(), 1u);
  const ModuleFailure& f = host.failures()[0];
  EXPECT_EQ(f.name, c.module);
  EXPECT_EQ(f.tag, c.tag);
  for (const auto& part : c.reason_has)
    EXPECT_NE(f.reason.find(part), std::string::npos) << f.reason;
  // One error line, tagged, naming the module and its file.
  const auto lines = capture.withTag(c.tag);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].level, log::Level::error);
  EXPECT_NE(lines[0].message.find(c.module), std::string::npos);
  EXPECT_NE(lines[0].message.find(testModule(c.module).string()), std::string::npos);

  const auto all = host.modules();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].name, "test_plain_c");
  EXPECT_EQ(all[1].name, "example");
  for (const auto& m : all) EXPECT_EQ(m.state, ModuleState::started);
  ASSERT_TRUE(runUntil([&] {
    return counter(testModule("test_plain_c"), "test_plain_c_ticks") >= 3 &&
           capture.count("EXAMPLE-TICK") >= 2;
  }));
  host.shutdown();
  EXPECT_EQ(capture.count("PLAIN-C-FINI"), 1u);
  EXPECT_EQ(capture.count("EXAMPLE-STOP"), 1u);
}

INSTANTIATE_TEST_SUITE_P(
    Cases, BadModule,
    ::testing::Values(
        BadCase{"test_no_entry", "MODULE-NO-ENTRY", {"skrobot_module_entry"}},
        BadCase{"test_abi_major",
                "MODULE-ABI",
                {"ABI 2.0", "ABI 1." + std::to_string(SKR_PLUGIN_ABI_MINOR)}},
        BadCase{"test_abi_minor",
                "MODULE-ABI",
                {"ABI 1." + std::to_string(SKR_PLUGIN_ABI_MINOR + 1),
                 "ABI 1." + std::to_string(SKR_PLUGIN_ABI_MINOR), "newer minor"}},
        BadCase{"test_bad_config_default",
                "MODULE-DESCRIPTOR",
                {"config key 'count': default 30 must be <= 10, got 30"}},
        BadCase{"test_short_descriptor", "MODULE-DESCRIPTOR", {"16 bytes"}},
        BadCase{"test_null_descriptor", "MODULE-DESCRIPTOR", {"no descriptor"}},
        BadCase{"garbage", "MODULE-LOAD", {"garbage.so"}},
        BadCase{"test_init_fails", "MODULE-INIT", {"cannot open /dev/robot-arm", "failed"}},
        BadCase{"test_init_status", "MODULE-INIT", {"returned status 2 (not found)"}},
        BadCase{"test_init_throws", "MODULE-INIT", {"boom in the constructor", "exception"}},
        BadCase{"test_start_fails", "MODULE-START", {"the motor is not powered"}}),
    [](const auto& info) { return std::string(info.param.module); });

TEST_F(ModuleHostTest, FailedStartRemovesRegistrationsAndCallsFiniNotStop) {
  ModuleHost host(loop, {});
  host.start({entry(testModule("test_start_fails")), entry(testModule("test_plain_c"))});
  ASSERT_NE(failureOf(host, "test_start_fails"), nullptr);
  EXPECT_EQ(capture.count("STARTFAIL-FINI"), 1u);
  ASSERT_TRUE(
      runUntil([&] { return counter(testModule("test_plain_c"), "test_plain_c_ticks") >= 5; }));
  EXPECT_EQ(capture.count("STARTFAIL-TICK"), 0u);
  host.shutdown();
  EXPECT_EQ(capture.count("STARTFAIL-STOP"), 0u);
}

TEST_F(ModuleHostTest, ConfigErrorNamesTheKeyAndFailsBeforeInit) {
  ModuleHost host(loop, {});
  host.start({entry(exampleModule(), exampleConfig("hi", 0)), entry(testModule("test_plain_c"))});
  const auto* f = failureOf(host, "example");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->tag, "MODULE-CONFIG");  // the example declares period_ms >= 1: never inited
  EXPECT_NE(f->reason.find("$.modules[0].config.period_ms"), std::string::npos) << f->reason;
  // One line for the problem (the module's source) and the module's failure line (the host's).
  const auto config = capture.withTag("MODULE-CONFIG");
  ASSERT_EQ(config.size(), 2u);
  EXPECT_EQ(config[0].source, "mod.example");
  EXPECT_EQ(config[0].message, "$.modules[0].config.period_ms: must be >= 1, got 0");
  EXPECT_EQ(config[1].source, "core.modules");
  EXPECT_EQ(capture.count("EXAMPLE-START"), 0u);
  ASSERT_EQ(host.modules().size(), 1u);
  EXPECT_EQ(host.modules()[0].state, ModuleState::started);
}

TEST_F(ModuleHostTest, ConfigGettersReadTypedValuesAndDefaultOnWrongTypes) {
  Json::Value good(Json::objectValue);
  good["label"] = "arm";
  good["factor"] = 3;
  good["ratio"] = 0.25;
  good["verbose"] = true;
  Json::Value bad(Json::objectValue);
  bad["label"] = 5;
  auto second = entry(testModule("test_plain_c"), bad);
  second.name = "plain_again";
  second.json_path = "$.modules[7]";
  ModuleHost host(loop, {});
  host.start({entry(testModule("test_plain_c"), good), second});
  const auto init = capture.messages("PLAIN-C-INIT");
  ASSERT_EQ(init.size(), 2u);
  EXPECT_EQ(init[0].rfind("label=arm factor=3 ratio=0.25 verbose=1 json={", 0), 0u) << init[0];
  EXPECT_EQ(init[1].rfind("label=none factor=1 ratio=0.50 verbose=0", 0), 0u) << init[1];
  const auto config = capture.withTag("MODULE-CONFIG");
  ASSERT_EQ(config.size(), 1u);
  EXPECT_EQ(config[0].source, "mod.plain_again");
  EXPECT_EQ(config[0].message.rfind("$.modules[7].config.label: expected a string", 0), 0u);
  EXPECT_EQ(capture.messages("PLAIN-C-START"),
            (std::vector<std::string>{"test_plain_c", "plain_again"}));
}

TEST_F(ModuleHostTest, RegistrationsAreRemovedAtStopEvenIfForgotten) {
  ModuleHost host(loop, {});
  const auto file = testModule("test_forgetful");
  host.load({entry(file)});
  host.initAll();
  // A handler added during init stays silent until start.
  runTicks(10);
  EXPECT_EQ(counter(file, "test_forgetful_ticks"), 0);

  host.startAll();
  ASSERT_TRUE(runUntil([&] { return counter(file, "test_forgetful_ticks") >= 5; }));
  host.stopAll();
  // The work it posted during stop was cancelled, never run.
  EXPECT_EQ(capture.count("FORGET-CANCEL"), 1u);
  const int frozen = counter(file, "test_forgetful_ticks");
  runTicks(20);
  EXPECT_EQ(counter(file, "test_forgetful_ticks"), frozen);
  EXPECT_EQ(capture.count("FORGET-RAN"), 0u);
  EXPECT_EQ(host.modules()[0].state, ModuleState::stopped);
  host.unloadAll();
  EXPECT_EQ(host.modules()[0].state, ModuleState::unloaded);
  EXPECT_TRUE(host.failures().empty());
}

TEST_F(ModuleHostTest, OwnThreadModuleRunsEveryStepOnItsThread) {
  ModuleHost host(loop, {});
  host.start({entry(testModule("test_own_thread"))});
  ASSERT_TRUE(host.failures().empty());
  ASSERT_EQ(host.modules().size(), 1u);
  EXPECT_TRUE(host.modules()[0].own_thread);
  ASSERT_TRUE(runUntil([&] { return capture.count("OWN-TICK") >= 1; }));
  // Host calls that belong to the loop thread refuse a foreign one.
  EXPECT_EQ(capture.messages("OWN-FOREIGN"),
            std::vector<std::string>{std::to_string(SKR_ERR_NOT_ON_LOOP_THREAD)});
  host.shutdown();

  std::vector<std::string> ids;
  for (const char* tag : {"OWN-INIT", "OWN-START", "OWN-TICK", "OWN-STOP", "OWN-FINI"}) {
    const auto got = capture.messages(tag);
    ASSERT_EQ(got.size(), 1u) << tag;
    ids.push_back(got[0]);
  }
  EXPECT_NE(ids[0], threadId());
  for (const auto& id : ids) EXPECT_EQ(id, ids[0]);
}

TEST_F(ModuleHostTest, ConfigCanPutAModuleOnItsOwnThread) {
  ModuleHost host(loop, {});
  auto e = entry(testModule("test_plain_c"));
  e.own_thread = true;
  host.start({e});
  ASSERT_EQ(host.modules().size(), 1u);
  EXPECT_TRUE(host.modules()[0].own_thread);
  // Its ticks come from its own loop, whether or not the main loop runs.
  ASSERT_TRUE(
      runUntil([&] { return counter(testModule("test_plain_c"), "test_plain_c_ticks") >= 3; }));
  host.shutdown();
  EXPECT_EQ(capture.count("PLAIN-C-FINI"), 1u);
}

TEST_F(ModuleHostTest, StopsInTheReverseOrderOfStart) {
  ModuleHost host(loop, {});
  host.start({entry(exampleModule(), exampleConfig("a", 50)), entry(testModule("test_plain_c")),
              entry(testModule("test_own_thread")), entry(testModule("test_forgetful"))});
  const std::vector<std::string> order = {"example", "test_plain_c", "test_own_thread",
                                          "test_forgetful"};
  EXPECT_EQ(host.startOrder(), order);
  runTicks(5);
  host.shutdown();
  std::vector<std::string> started, stopped;
  for (const auto& l : capture.withTag("MODULE-STARTED")) started.push_back(l.message);
  for (const auto& l : capture.withTag("MODULE-STOPPED")) stopped.push_back(l.message);
  ASSERT_EQ(started.size(), 4u);
  std::reverse(started.begin(), started.end());
  EXPECT_EQ(stopped, started);
  for (size_t i = 0; i < order.size(); ++i) {
    EXPECT_NE(stopped[i].find(order[order.size() - 1 - i]), std::string::npos) << stopped[i];
  }
}

TEST_F(ModuleHostTest, DestroyingTheHostStopsAndUnloads) {
  {
    ModuleHost host(loop, {});
    host.start({entry(exampleModule(), exampleConfig("bye", 5))});
    ASSERT_TRUE(runUntil([&] { return capture.count("EXAMPLE-TICK") >= 1; }));
  }
  EXPECT_EQ(capture.count("EXAMPLE-STOP"), 1u);
  runTicks(5);
}

TEST(ModuleFiles, ReadsADescriptorWithoutRunningTheModule) {
  auto info = readModuleDescriptor(exampleModule());
  ASSERT_TRUE(info.ok()) << info.error().describe();
  EXPECT_EQ(info->name, "example");
  EXPECT_EQ(info->version, "1.0.0");
  EXPECT_EQ(info->abi_major, SKR_PLUGIN_ABI_MAJOR);
  EXPECT_EQ(info->abi_minor, SKR_PLUGIN_ABI_MINOR);
  EXPECT_FALSE(info->description.empty());
}

TEST(ModuleFiles, ListsEverySharedObjectInTheSearchPath) {
  const auto listing = listModuleFiles({kTestModuleDir, kModuleDir, "/nonexistent"});
  std::map<std::string, const ModuleListing*> by_file;
  for (const auto& l : listing) by_file[l.file.filename().string()] = &l;
  ASSERT_TRUE(by_file.count("example.so"));
  ASSERT_TRUE(by_file["example.so"]->info.ok());
  EXPECT_EQ(by_file["example.so"]->info->name, "example");
  ASSERT_TRUE(by_file["test_own_thread.so"]->info.ok());
  EXPECT_NE(by_file["test_own_thread.so"]->info->flags & SKR_MODULE_WANTS_OWN_THREAD, 0u);
  EXPECT_EQ(by_file["test_plain_c.so"]->info->name, "plain_c");
  ASSERT_TRUE(by_file.count("garbage.so"));
  EXPECT_EQ(by_file["garbage.so"]->info.error().code, Errc::io_error);
  EXPECT_EQ(by_file["test_no_entry.so"]->info.error().code, Errc::not_found);
  EXPECT_EQ(by_file["test_abi_major.so"]->info.error().code, Errc::abi_mismatch);
  EXPECT_EQ(by_file["test_abi_minor.so"]->info.error().code, Errc::abi_mismatch);
  EXPECT_EQ(by_file["test_short_descriptor.so"]->info.error().code, Errc::parse_error);
}

// The host's contract names the main loop's thread: a call from another thread aborts.
TEST(ModuleHostDeathTest, CallsFromAnotherThreadAbort) {
  ::testing::GTEST_FLAG(death_test_style) = "threadsafe";
  Loop loop;
  ModuleHost host(loop, {});
  EXPECT_DEATH(
      {
        std::thread other([&] { host.load({}); });
        other.join();
      },
      "ModuleHost::load called off the thread that created the module host");
  host.load({});  // its own thread is fine
}

}  // namespace
}  // namespace skr
