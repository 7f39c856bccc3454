// SPDX-License-Identifier: Apache-2.0
// The frame pipeline every vision module runs: subscribe to a video channel, keep only the
// newest frame, decode and analyse it on worker threads, and hand the outcome back to the loop
// thread, which publishes it.
//
//   loop thread:   on data -> parse the media frame (count "frames" / "malformed")
//                  -> put it in the one-frame slot (a frame still waiting there is "skipped")
//   worker i:      take the newest frame -> decode (a corrupt JPEG is "malformed")
//                  -> analyse with its own Analyser -> host.post(outcome)
//   loop thread:   deliver(outcome) (the module publishes) -> "processed"
//
// The counters are written to the module's database ("<module name>"): frames, processed,
// skipped, malformed, limited (dropped by max_fps), late (an outcome for a frame older than one
// already delivered, possible with several workers; it is not delivered) and errors (the
// analyser threw; logged as VISION-ANALYSE).
#pragma once

#include <skrobot/media_frame.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>

#include <json/value.h>

#include <opencv2/core.hpp>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace skr::vision {

// The pixels a module wants from each frame.
enum class Pixels { grey, bgr };

// A decoded frame handed to an Analyser (worker thread).
struct FrameIn {
  media::FrameHeader header;  // seq, capture_ns; width/height are the decoded image's
  cv::Mat image;              // CV_8UC1 (grey) or CV_8UC3 (BGR)
};

// What an Analyser found in one frame, for the loop thread.
struct Outcome {
  std::uint64_t seq = 0;
  std::string payload;  // the message to publish
  std::string key;      // module-defined summary (qrcode: the set of codes), may be empty
};

// A result object with the fields every detection carries: {"seq":..,"capture_ns":..,
// "width":..,"height":..}; the caller adds its own and writes it with support::writeJson.
Json::Value resultObject(const FrameIn& frame);

// Per-worker analysis; not shared between threads. Called on its worker thread only.
using Analyser = std::function<Outcome(const FrameIn&)>;

struct PipelineOptions {
  std::string input;  // full channel name, <owner>.<name>
  int workers = 1;
  double max_fps = 0;  // 0: analyse every frame a worker can take
  Pixels pixels = Pixels::grey;
};

// The config keys of the pipeline, for a module's declaration (skrobot/support/config.hpp):
//   constexpr skr_config_key kConfig[] = {skr::vision::kInputKey, skr::vision::workersKey(8),
//                                         skr::vision::kMaxFpsKey, ...the module's own...};
// "input" is required: which channel feeds a module is the config's choice (config/default.json
// wires them), never a default naming another module.
inline constexpr skr_config_key kInputKey =
    config::string("input", nullptr, "the video channel to read, <owner>.<name>")
        .required()
        .nonEmpty();
constexpr skr_config_key workersKey(int max_workers) {
  return config::integer("workers", "1", "worker threads analysing frames").range(1, max_workers);
}
inline constexpr skr_config_key kMaxFpsKey =
    config::number("max_fps", "0", "frames analysed per second at most; 0: no limit").min(0);

// Reads "input", "workers" and "max_fps" (declared with the keys above, so the host has checked
// their types and ranges); refuses an input that is not a channel name with configError and
// Failure(SKR_ERR_CONFIG).
PipelineOptions readPipelineOptions(plugin::Host& host);

// Throws Failure(SKR_ERR_CONFIG) after host.configError(key, reason).
[[noreturn]] void configFailure(plugin::Host& host, const char* key, const std::string& reason);

class Pipeline {
 public:
  // Called on the loop thread in start(), once per worker.
  using AnalyserFactory = std::function<Analyser()>;
  // Called on the loop thread with each outcome, in the order the frames arrived.
  using Deliver = std::function<void(Outcome&&)>;

  Pipeline(plugin::Host& host, PipelineOptions options);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  // Loop thread, from the module's start(): subscribes and starts the workers.
  void start(const AnalyserFactory& factory, Deliver deliver);
  // Loop thread, from the module's stop() (idempotent): unsubscribes and joins the workers.
  void stop();

  [[nodiscard]] const PipelineOptions& options() const noexcept { return options_; }

 private:
  struct Counters {
    std::int64_t frames = 0, processed = 0, skipped = 0, malformed = 0, limited = 0, late = 0,
                 errors = 0;
  };
  struct Pending {
    std::uint64_t order = 0;  // arrival number, to spot late outcomes whatever the seq
    media::FrameHeader header;
    std::string payload;
  };

  void onData(std::string_view message);
  void workerLoop(Analyser analyse);
  void onOutcome(std::uint64_t order, Outcome&& outcome);
  void onMalformed();
  void publishCounter(const char* key, std::int64_t value);

  plugin::Host& host_;
  PipelineOptions options_;
  std::string db_;
  Deliver deliver_;
  plugin::Subscription sub_;
  std::vector<std::thread> threads_;

  // Shared with the workers.
  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<Pending> slot_;
  bool stopping_ = false;

  // Loop thread only.
  Counters counters_;
  std::int64_t next_accept_ns_ = 0;
  std::uint64_t arrivals_ = 0;
  std::optional<std::uint64_t> last_delivered_;  // arrival number of the last outcome
};

}  // namespace skr::vision
