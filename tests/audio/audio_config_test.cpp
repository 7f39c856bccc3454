// SPDX-License-Identifier: Apache-2.0
// The audio modules' declared config keys: the host refuses a value out of range and an unknown
// key (a typo) before init, naming the key; what the declarations cannot say is still checked
// by the modules; the declared defaults are enough to start.
#include "audio_test_util.h"

namespace skr::test {
namespace {

class AudioConfig : public ModuleFixture {
 protected:
  // The one failure of starting `file` as `name` with `config`; "" when it started.
  std::string failure(const std::string& file, const std::string& config) {
    const auto failures = startModule(file + std::to_string(next_++), config, false, file);
    EXPECT_LE(failures.size(), 1u);
    return failures.empty() ? std::string() : failures[0];
  }
  int next_ = 0;
};

#define EXPECT_FAILS_ON(failure_text, key)                                     \
  do {                                                                         \
    const std::string f = (failure_text);                                      \
    EXPECT_NE(f.find(std::string("config.") + (key)), std::string::npos) << f; \
  } while (false)

TEST_F(AudioConfig, OutOfRangeValuesAndUnknownKeysFailNamingTheKey) {
  startHub();
  EXPECT_FAILS_ON(failure("speech", R"({"rate":5})"), "rate");
  EXPECT_FAILS_ON(failure("speech", R"({"voise":"it"})"), "voise");
  EXPECT_FAILS_ON(failure("speech", R"({"voice":""})"), "voice");
  EXPECT_FAILS_ON(failure("vorbis", R"({"record":"guest.in","quality":2})"), "quality");
  EXPECT_FAILS_ON(failure("vorbis", R"({"record":"guest.in","rotate_s":"600"})"), "rotate_s");
  // audio-io's refusals are checked by `skrobot --check-config` (tests/hub/skrobot_cli_test.cpp):
  // loaded and refused in this process, libjack (under PortAudio) leaves allocations behind.
  EXPECT_FAILS_ON(failure("fft-audio", R"({"input":"guest.in","window":"triangle"})"), "window");
  EXPECT_FAILS_ON(failure("fft-audio", R"({"input":"guest.in","sise":512})"), "sise");
}

// Init fails with "invalid <key>" (the module logs the reason as MODULE-CONFIG).
TEST_F(AudioConfig, RulesBeyondTheDeclarationsAreTheModulesOwn) {
  startHub();
  std::string f = failure("fft-audio", R"({"input":"guest.in","size":512,"hop":1024})");
  EXPECT_NE(f.find("invalid hop"), std::string::npos) << f;
  f = failure("vorbis", R"({"record":"guest.in","prefix":"a/b"})");
  EXPECT_NE(f.find("invalid prefix"), std::string::npos) << f;
}

TEST_F(AudioConfig, TheDeclaredDefaultsStartTheModules) {
  startHub();
  EXPECT_EQ(failure("speech", "{}"), "");
  EXPECT_EQ(failure("vorbis", "{}"), "");
  EXPECT_EQ(failure("fft-audio", R"({"input":"guest.in"})"), "");
}

}  // namespace
}  // namespace skr::test
