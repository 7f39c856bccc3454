// SPDX-License-Identifier: Apache-2.0
// The tutorial module: every part of the module API in one small file (docs/plugins.md).
//
// Config (the "config" object of its entry in the hub's JSON): declared in kConfig below, so the
// host checks it before init and `skrobot --describe-module example` prints it.
// Log tags: EXAMPLE-START, EXAMPLE-TICK (every period_ms), EXAMPLE-WORK (a result computed on a
// worker thread and posted back to the loop), EXAMPLE-SECOND (debug), EXAMPLE-STOP.
#include <skrobot/plugin.hpp>
#include <skrobot/support/config.hpp>

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace {

using skr::plugin::Host;
using skr::plugin::Tick;

class Example final : public skr::plugin::Module {
 public:
  // init: read the config. The host has already checked it against kConfig (types, range,
  // unknown keys) and filled in the defaults. A rule the declaration cannot express would be
  // checked here: host.configError(key, reason), then throw Failure(SKR_ERR_CONFIG, ...).
  // Throwing fails init; the host logs the message and unloads the module. Nothing runs yet:
  // ticks registered now would only start after start().
  explicit Example(Host& host)
      : host_(host),
        greeting_(host.configString("greeting")),
        period_ms_(host.configInt("period_ms")) {}

  // start: register tick handlers and start the worker. Runs on the module's loop thread.
  void start() override {
    next_tick_ns_ = host_.nowNs() + period_ms_ * 1'000'000;
    // FastTick is the loop's resolution: check a deadline there, never sleep in a handler.
    fast_ = host_.onTick(Tick::fast, [this] {
      const std::int64_t now = host_.nowNs();
      if (now < next_tick_ns_) return;
      const std::int64_t period_ns = period_ms_ * 1'000'000;
      next_tick_ns_ += period_ns;  // absolute deadlines: no drift
      if (next_tick_ns_ <= now) next_tick_ns_ = now + period_ns;
      host_.log.info("EXAMPLE-TICK", greeting_, " #", ++ticks_);
      wakeWorker();  // hand the worker a job
    });
    slow_ = host_.onTick(Tick::slow, [this] { ++slow_ticks_; });
    second_ = host_.onTick(Tick::one_sec, [this] {
      host_.log.debug("EXAMPLE-SECOND", slow_ticks_, " slow ticks so far");
    });
    worker_ = std::thread([this] { work(); });
    host_.log.info("EXAMPLE-START", "greeting '", greeting_, "', period ", period_ms_, " ms on ",
                   host_.loopInfo().loop_name);
  }

  // reconfigure (ABI 1.11): a reload of the hub's config changed ours while we run. The host has
  // checked the new one against kConfig; we take it in place, from the next tick on (returning
  // false instead would have the host restart us with it).
  bool reconfigure() override {
    greeting_ = host_.configString("greeting");
    period_ms_ = host_.configInt("period_ms");
    next_tick_ns_ = host_.nowNs() + period_ms_ * 1'000'000;
    host_.log.info("EXAMPLE-RECONFIGURED", "greeting '", greeting_, "', period ", period_ms_,
                   " ms");
    return true;
  }

  // stop: undo start (called once, only after a successful start). Join our own thread first so
  // that nothing posts afterwards; the host then drops work we posted that has not run yet (its
  // lambda is destroyed, never called).
  void stop() override {
    {
      std::lock_guard lock(mutex_);
      quit_ = true;
    }
    wake_.notify_one();
    if (worker_.joinable()) worker_.join();
    fast_.reset();  // optional: the host removes forgotten handlers at stop anyway
    slow_.reset();
    second_.reset();
    host_.log.info("EXAMPLE-STOP", ticks_, " ticks, ", results_, " results");
  }

 private:
  void wakeWorker() {
    {
      std::lock_guard lock(mutex_);
      ++jobs_;
    }
    wake_.notify_one();
  }

  // The worker thread: "heavy" work happens here, never on the loop. Results go back to the
  // loop with post(), which is the only host call a foreign thread may make (besides log).
  void work() {
    std::unique_lock lock(mutex_);
    while (true) {
      wake_.wait(lock, [this] { return quit_ || jobs_ > 0; });
      if (quit_) return;
      const int job = jobs_--;
      lock.unlock();
      std::uint64_t sum = 0;
      for (std::uint64_t i = 0; i < 100'000; ++i) sum += i * static_cast<std::uint64_t>(job);
      host_.post([this, sum] {  // runs on the loop thread, like a tick handler
        host_.log.info("EXAMPLE-WORK", "result ", ++results_, ": ", sum);
      });
      lock.lock();
    }
  }

  Host& host_;
  std::string greeting_;  // loop thread only (read in ticks, changed by reconfigure)
  std::int64_t period_ms_;
  skr::plugin::TickHandle fast_, slow_, second_;  // RAII: a reset handle is unregistered
  std::int64_t next_tick_ns_ = 0;
  std::uint64_t ticks_ = 0, slow_ticks_ = 0, results_ = 0;  // loop thread only

  std::thread worker_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool quit_ = false;
  int jobs_ = 0;
};

}  // namespace

// The config keys: type, default, range and a line of description each.
constexpr skr_config_key kConfig[] = {
    skr::config::string("greeting", "hello", "logged with every EXAMPLE-TICK line"),
    skr::config::integer("period_ms", "1000", "the EXAMPLE-TICK period, in milliseconds")
        .range(1, 3'600'000),
};

SKR_MODULE_WITH_CONFIG(Example, "example", "1.0.0", "Tutorial: config, log, ticks, a worker thread",
                       0, kConfig)
