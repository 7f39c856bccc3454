// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop_handles.h>
#include <skrobot/satellite/sketch.h>

#include <algorithm>
#include <cmath>

namespace skr::sat {

Result<SketchOptions> SketchOptions::fromEnvironment(std::string client_name) {
  auto s = SatelliteOptions::fromEnvironment(std::move(client_name));
  if (!s) return s.error();
  SketchOptions o;
  o.satellite = std::move(s).value();
  return o;
}

namespace {

LoopOptions loopOptions(const SketchOptions& o) {
  LoopOptions l;
  l.name = "sketch";
  l.mode = o.timing;
  const double hz = o.rate_hz > 0 && std::isfinite(o.rate_hz) ? o.rate_hz : 10;
  l.fast_interval_ns = static_cast<Nanos>(static_cast<double>(kNsPerSec) / hz);
  l.slow_interval_ns = std::max<Nanos>(l.fast_interval_ns, 100 * kNsPerMs);
  return l;
}

}  // namespace

Sketch::Sketch() {
  auto o = SketchOptions::fromEnvironment();
  if (o) {
    options_ = std::move(o).value();
  } else {
    log::error("satellite", "SAT-OPTIONS", o.error().message);
    options_ok_ = false;
  }
  loop_ = std::make_unique<Loop>(loopOptions(options_));
  satellite_ = std::make_unique<Satellite>(*loop_, options_.satellite);
}

Sketch::Sketch(SketchOptions options)
    : options_(std::move(options)),
      loop_(std::make_unique<Loop>(loopOptions(options_))),
      satellite_(std::make_unique<Satellite>(*loop_, options_.satellite)) {}

Sketch::~Sketch() {
  satellite_.reset();  // before its loop
  loop_.reset();
}

void Sketch::stop() noexcept {
  loop_->stop();
}

int Sketch::run() {
  if (!options_ok_) return 2;
  Satellite& s = *satellite_;
  s.connected.connect(&s, [this] {
    noteTickMode();
    onConnected();
    if (!set_up_) {
      set_up_ = true;
      setup();
    }
  });
  s.disconnected.connect(&s, [this](const std::string& why) { onDisconnected(why); });
  s.channelReady.connect(&s, [this](const ChannelInfo& i) { onChannelReady(i); });
  s.subscribed.connect(&s, [this](const ChannelInfo& i) { onSubscribed(i); });
  s.channelAdded.connect(&s, [this](const ChannelInfo& i) { onChannelAdded(i); });
  s.channelRemoved.connect(&s, [this](const ChannelInfo& i) { onChannelRemoved(i); });
  s.startPublish.connect(&s, [this](uint16_t id) { onStartPublish(id); });
  s.stopPublish.connect(&s, [this](uint16_t id) { onStopPublish(id); });
  s.data.connect(&s, [this](uint16_t id, const std::string& p) { onData(id, p); });
  s.serviceRequest.connect(&s, [this](const Request& r) { onRequest(r); });
  s.serviceResponse.connect(&s, [this](const Response& r) { onResponse(r); });
  s.error.connect(&s, [this](const FlowError& e) { onError(e); });
  const bool following = !options_.sync_source.empty();
  if (following) {
    s.follow(options_.sync_source, options_.sync_every);
    s.syncPulse.connect(&s, [this](const SyncPulse& p) { onPulse(p); });
    last_pulse_ns_ = monotonicNs();
  }
  const TickId tick = loop_->addTickHandler(Tick::fast, [this, following] {
    if (following) {
      ownTick();
    } else {
      this->tick();
    }
  });

  // SIGINT/SIGTERM stop the loop (on the loop thread: nothing runs in signal context).
  StopOnSignals signals;
  if (options_.handle_signals) signals = stopOnSignals(*loop_);
  s.start();
  window_start_ns_ = monotonicNs();
  loop_->run();
  s.stop();
  loop_->removeTickHandler(tick);
  return 0;
}

void Sketch::noteTickMode() {
  Satellite& s = *satellite_;
  const std::string db = "_flow." + std::to_string(s.login().connection_id);
  std::string mode(timingModeName(loop_->options().mode));
  if (!options_.sync_source.empty()) mode = options_.sync_strict ? "sync-strict" : "sync";
  (void)s.set("tick_mode", flow::Variant(mode), db);
  (void)s.set("tick_interval_ms",
              flow::Variant(static_cast<double>(loop_->options().fast_interval_ns) / kNsPerMs), db);
}

void Sketch::tick() {
  const Nanos start = monotonicNs();
  stats_.requested_hz =
      static_cast<double>(kNsPerSec) / static_cast<double>(loop_->options().fast_interval_ns);
  if (last_tick_ns_ != 0) {
    const double err = std::abs(static_cast<double>(start - last_tick_ns_) -
                                static_cast<double>(loop_->options().fast_interval_ns));
    window_error_sum_ns_ += err;
    window_error_max_ns_ = std::max(window_error_max_ns_, err);
  }
  last_tick_ns_ = start;
  ++window_ticks_;
  if (set_up_) {
    loop();
    ++stats_.loops;
    ++window_loops_;
  }
  window_work_sum_ += static_cast<double>(monotonicNs() - start) /
                      static_cast<double>(loop_->options().fast_interval_ns);
  if (start - window_start_ns_ >= kNsPerSec) measureSecond();
}

void Sketch::onPulse(const SyncPulse& pulse) {
  last_pulse_ns_ = pulse.arrival_ns;
  if (sync_lost_) {
    sync_lost_ = false;
    log::info("satellite", "SAT-SYNC-BACK", "pulses of " + options_.sync_source + " again");
  }
  onSyncPulse(pulse);
  tick();
}

void Sketch::ownTick() {
  const Nanos timeout = Nanos(options_.sync_timeout_ms) * kNsPerMs;
  if (monotonicNs() - last_pulse_ns_ < timeout) return;  // the pulses drive loop()
  if (!sync_lost_) {
    sync_lost_ = true;
    log::warn("satellite", "SAT-SYNC-LOST",
              "no pulse of " + options_.sync_source + " for " +
                  std::to_string(options_.sync_timeout_ms) + " ms: " +
                  (options_.sync_strict ? "loop() waits for them"
                                        : "loop() runs on the sketch's own timer meanwhile"));
    onSyncLost();
  }
  if (!options_.sync_strict) tick();
}

void Sketch::measureSecond() {
  const Nanos now = monotonicNs();
  const double elapsed_s = static_cast<double>(now - window_start_ns_) / kNsPerSec;
  const double ticks = static_cast<double>(std::max<uint64_t>(window_ticks_, 1));
  stats_.measured_hz = elapsed_s > 0 ? static_cast<double>(window_loops_) / elapsed_s : 0;
  stats_.period_error_mean_ms = window_error_sum_ns_ / ticks / kNsPerMs;
  stats_.period_error_max_ms = window_error_max_ns_ / kNsPerMs;
  stats_.work_ratio_mean = window_work_sum_ / ticks;
  stats_.skipped = loop_->stats().skipped_ticks;
  window_start_ns_ = now;
  window_loops_ = 0;
  window_ticks_ = 0;
  window_error_sum_ns_ = window_error_max_ns_ = window_work_sum_ = 0;
}

}  // namespace skr::sat
