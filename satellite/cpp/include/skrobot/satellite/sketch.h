// SPDX-License-Identifier: Apache-2.0
// A sketch: a satellite written as setup() once and loop() at a steady rate, with virtual event
// hooks. It owns its skr::Loop (loop() is its FastTick, from absolute deadlines) and a Satellite.
//
//   struct Counter : skr::sat::Sketch {
//     void setup() override { (void)satellite().addChannel({.name = "counter"}); }
//     void loop() override {
//       if (satellite().hasSubscribers("counter"))
//         (void)satellite().publish("counter", std::to_string(n++));
//     }
//     int n = 0;
//   };
//   int main() { Counter c; return c.run(); }
//
// Threading: run() blocks the calling thread, which becomes the sketch's loop thread; every hook
// runs there. stop() may be called from any thread (and from a signal handler through SIGINT /
// SIGTERM, which run() handles when SketchOptions::handle_signals is set).
#pragma once

#include <skrobot/satellite/satellite.h>

#include <memory>

namespace skr::sat {

struct SketchOptions {
  SatelliteOptions satellite;  // by default from ROBOT_ADDRESS / ROBOT_USER / ROBOT_PASSWORD
  double rate_hz = 10;         // loop() calls per second
  TimingMode timing = TimingMode::coarse;
  bool handle_signals = true;  // SIGINT and SIGTERM make run() return 0
  // Follow a sync source ("<user>.<name>", docs/sync-pulse.md): loop() runs on each of its
  // pulses (every sync_every-th) instead of at rate_hz. After sync_timeout_ms without a pulse,
  // loop() runs at rate_hz again until pulses come back (onSyncLost once per loss), or, with
  // sync_strict, does not run at all.
  std::string sync_source;
  uint32_t sync_every = 1;
  uint32_t sync_timeout_ms = 1000;
  bool sync_strict = false;

  // SatelliteOptions::fromEnvironment(); ROBOT_ADDRESS must parse.
  [[nodiscard]] static Result<SketchOptions> fromEnvironment(std::string client_name = {});
};

// How well the sketch keeps its cadence, over the last whole second.
struct SketchStats {
  double requested_hz = 0;
  double measured_hz = 0;           // loop() calls per second
  double period_error_mean_ms = 0;  // |actual period - requested period|, mean
  double period_error_max_ms = 0;   // ... and maximum
  double work_ratio_mean = 0;       // time in loop() / period
  uint64_t loops = 0;               // loop() calls so far
  uint64_t skipped = 0;             // periods skipped because loop() overran
};

class Sketch {
 public:
  // Builds the loop and the satellite; connects only in run(). A bad ROBOT_ADDRESS is logged
  // and run() then returns 2.
  Sketch();
  explicit Sketch(SketchOptions options);
  virtual ~Sketch();
  Sketch(const Sketch&) = delete;
  Sketch& operator=(const Sketch&) = delete;
  Sketch(Sketch&&) = delete;
  Sketch& operator=(Sketch&&) = delete;

  // Connects, calls setup() once when the flow first opens, then loop() at rate_hz until
  // stop(). Returns 0, or 2 when the options were unusable. Blocks; call it once.
  int run();
  // Makes run() return after the current hook. Any thread; idempotent.
  void stop() noexcept;

  [[nodiscard]] Satellite& satellite() noexcept { return *satellite_; }
  [[nodiscard]] Loop& eventLoop() noexcept { return *loop_; }
  // Loop thread, or after run() returned.
  [[nodiscard]] const SketchStats& stats() const noexcept { return stats_; }

 protected:
  virtual void setup() {}
  virtual void loop() {}
  // Event hooks; the defaults do nothing. See Satellite's signals for their meaning.
  virtual void onConnected() {}
  virtual void onDisconnected(const std::string& /*why*/) {}
  virtual void onChannelReady(const ChannelInfo& /*info*/) {}
  virtual void onSubscribed(const ChannelInfo& /*info*/) {}
  virtual void onChannelAdded(const ChannelInfo& /*info*/) {}
  virtual void onChannelRemoved(const ChannelInfo& /*info*/) {}
  virtual void onStartPublish(uint16_t /*chan_id*/) {}
  virtual void onStopPublish(uint16_t /*chan_id*/) {}
  virtual void onData(uint16_t /*chan_id*/, const std::string& /*payload*/) {}
  virtual void onRequest(const Request& /*request*/) {}
  virtual void onResponse(const Response& /*response*/) {}
  virtual void onError(const FlowError& /*error*/) {}
  // Following a sync source: each pulse, before its loop(); and a loss of pulses (timeout).
  virtual void onSyncPulse(const SyncPulse& /*pulse*/) {}
  virtual void onSyncLost() {}

 private:
  void tick();
  void measureSecond();
  void onPulse(const SyncPulse& pulse);
  void ownTick();       // the loop's fast tick while following: the fallback after a timeout
  void noteTickMode();  // tick_mode and tick_interval_ms in the flow's database

  SketchOptions options_;
  bool options_ok_ = true;
  std::unique_ptr<Loop> loop_;
  std::unique_ptr<Satellite> satellite_;
  bool set_up_ = false;
  SketchStats stats_;
  Nanos last_tick_ns_ = 0;
  Nanos window_start_ns_ = 0;
  uint64_t window_loops_ = 0;
  uint64_t window_ticks_ = 0;
  double window_error_sum_ns_ = 0;
  double window_error_max_ns_ = 0;
  double window_work_sum_ = 0;
  Nanos last_pulse_ns_ = 0;  // following: the last pulse's arrival (or when following began)
  bool sync_lost_ = false;
};

}  // namespace skr::sat
