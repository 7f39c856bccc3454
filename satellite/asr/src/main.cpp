// SPDX-License-Identifier: Apache-2.0
// skrobot-asr: the speech-recognition satellite (docs/asr.md).
//
//   skrobot-asr [--input CHANNEL] [--name NAME] [--mode dictation|grammar]
//               [--grammar FILE.gram | --keywords FILE] [--max-utterance-s N] [--hangover-ms N]
//               [--max-behind-s N] [--model DIR] [--reject-threshold X] [--max-unplaced X]
//               [--no-reject]
//               [--address ADDR] [--user NAME] [--password PW]
#include "asr_satellite.h"
#include "pocketsphinx_engine.h"

#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop_handles.h>
#include <skrobot/satellite.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace {

constexpr const char* kUsage = R"(usage: skrobot-asr [options]
  --input CHANNEL        the audio channel to listen to (default websocket-ui.mic)
  --name NAME            the instance: publishes NAME.transcript, serves NAME.control (default asr)
  --mode MODE            dictation (default) or grammar (needs --grammar or --keywords)
  --grammar FILE         a JSGF grammar (grammar mode)
  --keywords FILE        phrases, one a line (grammar mode; "/1e-20/" thresholds are ignored)
  --max-utterance-s N    an utterance is cut at this length (default 15, 1..120)
  --hangover-ms N        silence that ends an utterance (default 300, 50..3000)
  --max-behind-s N       audio the recogniser may fall behind by; beyond it the utterance being
                         heard is dropped (default 30, 1..3600)
  --model DIR            pocketsphinx model (default /usr/share/pocketsphinx/model/en-us)
  --reject-threshold X   grammar mode: reject above this score per frame (default 5; docs/asr.md)
  --max-unplaced X       grammar mode: reject when more of the speech than this share (0..1)
                         fits no word of the grammar (default 0.4; docs/asr.md)
  --no-reject            grammar mode: never reject (the closest phrase of the grammar wins)
  --address ADDR         the hub (default $ROBOT_ADDRESS, else local:/tmp/Robot)
  --user NAME            (default $ROBOT_USER, else guest)
  --password PW          (default $ROBOT_PASSWORD, else password)
  --log-level LEVEL      debug, info (default), warn, error
)";

int usage(const std::string& why) {
  std::fprintf(stderr, "skrobot-asr: %s\n%s", why.c_str(), kUsage);
  return 2;
}

bool readFile(const std::string& path, std::string& out) {
  std::ifstream in(path);
  if (!in) return false;
  std::stringstream ss;
  ss << in.rdbuf();
  out = ss.str();
  return true;
}

bool number(const std::string& text, double lo, double hi, double& out) {
  char* end = nullptr;
  out = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && out >= lo && out <= hi;
}

}  // namespace

// Debian's sphinxbase 5prealpha leaks what its JSGF parser allocates for each grammar
// (ckd_calloc, yylex's strdup): a sanitized build is told to ignore leaks from that library, and
// only those (an ordinary build never calls this).
extern "C" const char* __lsan_default_suppressions() {  // NOLINT(bugprone-reserved-identifier)
  return "leak:libsphinxbase.so\n";
}

int main(int argc, char** argv) {
  using namespace skr;
  asr::AsrOptions options;
  asr::PocketsphinxOptions engine_options;
  std::string mode = "dictation", grammar_file, keywords_file, address, user, password;
  bool have_user = false, have_password = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (arg == "--no-reject") {
      engine_options.reject = false;
      continue;
    }
    if (i + 1 >= argc) return usage("missing value after " + arg);
    const std::string value = argv[++i];
    double x = 0;
    if (arg == "--input") {
      options.input = value;
    } else if (arg == "--name") {
      if (value.empty()) return usage("empty --name");
      options.name = value;
    } else if (arg == "--mode") {
      if (value != "dictation" && value != "grammar") return usage("bad --mode " + value);
      mode = value;
    } else if (arg == "--grammar") {
      grammar_file = value;
    } else if (arg == "--keywords") {
      keywords_file = value;
    } else if (arg == "--max-utterance-s") {
      if (!number(value, 1, 120, x)) return usage("--max-utterance-s: 1..120");
      options.segmenter.max_utterance_s = x;
    } else if (arg == "--hangover-ms") {
      if (!number(value, 50, 3000, x)) return usage("--hangover-ms: 50..3000");
      options.segmenter.vad.hangover_ms = static_cast<int>(x);
    } else if (arg == "--max-behind-s") {
      if (!number(value, 1, 3600, x)) return usage("--max-behind-s: 1..3600");
      options.max_queued_s = x;
    } else if (arg == "--model") {
      engine_options.model_dir = value;
    } else if (arg == "--reject-threshold") {
      if (!number(value, -1000, 1000, x)) return usage("--reject-threshold: -1000..1000");
      engine_options.reject_threshold = x;
    } else if (arg == "--max-unplaced") {
      if (!number(value, 0, 1, x)) return usage("--max-unplaced: 0..1");
      engine_options.max_unplaced = x;
    } else if (arg == "--address") {
      address = value;
    } else if (arg == "--user") {
      user = value;
      have_user = true;
    } else if (arg == "--password") {
      password = value;
      have_password = true;
    } else if (arg == "--log-level") {
      log::Level level;
      if (!log::parseLevel(value, level)) return usage("bad --log-level " + value);
      log::setLevel(level);
    } else {
      return usage("unknown option " + arg);
    }
  }
  if (!grammar_file.empty() && !keywords_file.empty()) {
    return usage("--grammar and --keywords: one or the other");
  }
  if (!grammar_file.empty() && !readFile(grammar_file, options.grammar_jsgf)) {
    return usage("cannot read " + grammar_file);
  }
  if (!keywords_file.empty()) {
    std::string text;
    if (!readFile(keywords_file, text)) return usage("cannot read " + keywords_file);
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      if (const auto slash = line.find('/'); slash != std::string::npos) line.resize(slash);
      if (line.find_first_not_of(" \t\r") != std::string::npos) options.keywords.push_back(line);
    }
    if (options.keywords.empty()) return usage(keywords_file + " has no phrases");
  }
  const bool has_grammar = !options.grammar_jsgf.empty() || !options.keywords.empty();
  if (mode == "grammar" && !has_grammar)
    return usage("--mode grammar needs --grammar or --keywords");
  if (mode == "dictation" && has_grammar) mode = "grammar";  // a grammar given means grammar mode

  auto sat_options = sat::SatelliteOptions::fromEnvironment("skrobot-asr " + options.name);
  if (!sat_options && address.empty()) {
    std::fprintf(stderr, "skrobot-asr: %s\n", sat_options.error().message.c_str());
    return 2;
  }
  sat::SatelliteOptions so = sat_options ? std::move(sat_options).value() : sat::SatelliteOptions{};
  if (!address.empty()) {
    auto parsed = sat::Address::parse(address);
    if (!parsed) return usage(parsed.error().message);
    so.connection.address = std::move(parsed).value();
  }
  if (have_user) so.connection.user = user;
  if (have_password) so.connection.password = password;

  auto engine = asr::PocketsphinxEngine::create(engine_options);
  if (!engine) {
    log::error("asr", "ASR-ENGINE", engine.error().describe());
    return 1;
  }
  log::info("asr", "ASR-START",
            "instance " + options.name + " listening to " + options.input + " (" + mode +
                " mode, pocketsphinx, hang-over " +
                std::to_string(options.segmenter.vad.hangover_ms) + " ms, max utterance " +
                std::to_string(options.segmenter.max_utterance_s) + " s)");

  // Nothing ticks here: audio arrives as events. A slow fast tick keeps an idle process asleep.
  Loop loop(LoopOptions{
      .name = "asr", .fast_interval_ns = 200 * kNsPerMs, .slow_interval_ns = 1000 * kNsPerMs});
  sat::Satellite sat(loop, std::move(so));
  asr::AsrSatellite asr(loop, sat, options, std::move(engine).value());

  const auto signals = stopOnSignals(loop);
  sat.start();
  loop.run();
  sat.stop();
  log::info("asr", "ASR-STOP", "instance " + options.name + " stopped");
  return 0;
}
