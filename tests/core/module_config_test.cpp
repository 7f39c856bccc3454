// SPDX-License-Identifier: Apache-2.0
// Declared config keys (ABI 1.2) through the module host: checked before init, each problem at
// its key's path, defaults filled in; checkModules (what `skrobot --check-config` runs) reports the
// same without initialising anything. Modules built for ABI 1.0 and 1.1 (no declared keys, config
// unchecked) are compiled against the frozen headers in tests/modules/abi/abi_compat_test.sh.
#include "log_capture.h"

#include <skrobot/hub/module_host.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/support/json.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

namespace skr {
namespace {

namespace fs = std::filesystem;

fs::path testModule(const std::string& name) {
  return fs::path(SKROBOT_TEST_MODULE_DIR) / (name + ".so");
}

ModuleEntry entry(const std::string& module, const std::string& config_json) {
  ModuleEntry e;
  e.name = module;
  e.path = testModule(module);
  auto parsed = support::parseJsonObject(config_json);
  EXPECT_TRUE(parsed.ok()) << parsed.error().message;
  if (parsed.ok()) e.config = std::move(parsed).value();
  return e;
}

// Messages of the lines with `tag`.
std::vector<std::string> tagged(const test::LogCapture& capture, const std::string& tag) {
  std::vector<std::string> out;
  for (const auto& l : capture.lines()) {
    if (l.rfind(tag + " ", 0) == 0) out.push_back(l.substr(tag.size() + 1));
  }
  return out;
}

// The MODULE-CONFIG lines of single problems ("$.modules[N].config.<key>: <reason>"), sorted;
// the module's failure line (also MODULE-CONFIG, "module <name> (<file>): ...") is left out.
std::vector<std::string> problemLines(const test::LogCapture& capture) {
  std::vector<std::string> out;
  for (auto& m : tagged(capture, "MODULE-CONFIG")) {
    if (m.rfind("$.", 0) == 0) out.push_back(std::move(m));
  }
  std::sort(out.begin(), out.end());
  return out;
}

class ModuleConfigTest : public ::testing::Test {
 protected:
  void SetUp() override { unsetenv("SKROBOT_MODULE_PATH"); }
  test::LogCapture capture;
  Loop loop;
};

TEST_F(ModuleConfigTest, DeclaredDefaultsAreWhatTheGettersReturn) {
  ModuleHost host(loop, {});
  host.start({entry("test_config_keys", R"({"input": "cam.frames"})")});
  ASSERT_TRUE(host.failures().empty()) << host.failures()[0].reason;
  const auto init = tagged(capture, "CONFIG-KEYS-INIT");
  ASSERT_EQ(init.size(), 1u);
  EXPECT_EQ(init[0],
            "label=arm count=3 ratio=0.5 on=1 input=cam.frames has_list=0 "
            R"(json={"count":3,"extra":{},"input":"cam.frames","label":"arm","on":true,)"
            R"("ratio":0.5})");
}

TEST_F(ModuleConfigTest, GivenValuesWin) {
  ModuleHost host(loop, {});
  host.start({entry("test_config_keys", R"({"input": "a.b", "label": "leg", "count": 10,
                                            "ratio": 2, "on": false, "list": [1, "x"]})")});
  ASSERT_TRUE(host.failures().empty()) << host.failures()[0].reason;
  const auto init = tagged(capture, "CONFIG-KEYS-INIT");
  ASSERT_EQ(init.size(), 1u);
  EXPECT_EQ(init[0].rfind("label=leg count=10 ratio=2 on=0 input=a.b has_list=1 ", 0), 0u)
      << init[0];
}

TEST_F(ModuleConfigTest, EveryProblemIsAnErrorAtItsPathAndTheModuleIsNeverInited) {
  ModuleHost host(loop, {});
  host.start({entry("test_config_keys", R"({"label": "hand", "count": 11, "ratio": "x",
                                            "list": [1, 2, 3], "extra": 5, "colour": 1,
                                            "on": 1})"),
              entry("test_plain_c", "{}")});
  ASSERT_EQ(host.failures().size(), 1u);
  const ModuleFailure& f = host.failures()[0];
  EXPECT_EQ(f.name, "test_config_keys");
  EXPECT_EQ(f.tag, "MODULE-CONFIG");
  EXPECT_TRUE(tagged(capture, "CONFIG-KEYS-INIT").empty()) << "init must not run";
  const std::vector<std::string> lines = problemLines(capture);
  const std::string p = "$.modules[0].config.";
  std::vector<std::string> expected = {
      p + "colour: unknown key",
      p + "count: must be <= 10, got 11",
      p + "extra: expected object, got integer",
      p + "input: required key missing",
      p + "label: must be one of \"arm\", \"leg\", got \"hand\"",
      p + "list: must have at most 2 items, got 3",
      p + "on: expected boolean, got integer",
      p + "ratio: expected number, got string",
  };
  EXPECT_EQ(lines, expected);
  // The other module runs.
  ASSERT_EQ(host.modules().size(), 1u);
  EXPECT_EQ(host.modules()[0].state, ModuleState::started);
}

TEST_F(ModuleConfigTest, IntegersMustBeIntegralAndStringsNonEmpty) {
  ModuleHost host(loop, {});
  host.start({entry("test_config_keys", R"({"input": "", "count": 2.5})")});
  const std::vector<std::string> lines = problemLines(capture);
  EXPECT_EQ(lines, (std::vector<std::string>{
                       "$.modules[0].config.count: expected integer, got non-integral number",
                       "$.modules[0].config.input: must not be empty"}));
}

TEST_F(ModuleConfigTest, TheDescriptorCarriesTheDeclaredKeys) {
  auto info = readModuleDescriptor(testModule("test_config_keys"));
  ASSERT_TRUE(info.ok()) << info.error().message;
  ASSERT_TRUE(info->declares_config);
  ASSERT_EQ(info->config_keys.size(), 7u);
  const ModuleConfigKey& count = info->config_keys[1];
  EXPECT_EQ(count.key, "count");
  EXPECT_EQ(count.type, ConfigType::integer);
  EXPECT_EQ(count.default_value, Json::Value(3));
  EXPECT_EQ(count.min, 1.0);
  EXPECT_EQ(count.max, 10.0);
  EXPECT_EQ(count.description, "how many");
  EXPECT_EQ(info->config_keys[0].choices, (std::vector<std::string>{"arm", "leg"}));
  EXPECT_TRUE(info->config_keys[4].required);
}

TEST_F(ModuleConfigTest, CheckModulesReportsWithoutInitialising) {
  std::vector<ModuleEntry> entries = {entry("test_config_keys", R"({"count": 0})"),
                                      entry("test_config_keys", R"({"input": "a.b"})"),
                                      entry("no_such_module", "{}")};
  entries[1].json_path = "$.modules[7]";
  entries[2].path.clear();
  const auto checks = checkModules(entries, {SKROBOT_TEST_MODULE_DIR});
  ASSERT_EQ(checks.size(), 3u);
  EXPECT_EQ(checks[0].tag, "MODULE-CONFIG");
  ASSERT_EQ(checks[0].config_problems.size(), 2u);
  EXPECT_EQ(checks[0].config_problems[0].path, "$.modules[0].config.count");
  EXPECT_EQ(checks[0].config_problems[1].path, "$.modules[0].config.input");
  EXPECT_TRUE(checks[1].ok()) << checks[1].reason;
  EXPECT_EQ(checks[1].json_path, "$.modules[7]");
  EXPECT_EQ(checks[2].tag, "MODULE-NOT-FOUND");
  EXPECT_TRUE(tagged(capture, "CONFIG-KEYS-INIT").empty());
}

}  // namespace
}  // namespace skr
