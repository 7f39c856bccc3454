// SPDX-License-Identifier: Apache-2.0
// primes: a complete small module, built out of tree (docs/plugins.md, "Your first module in ten
// minutes"). While someone subscribes to its streaming channel primes.count, a tick hands the
// worker thread a growing limit every period_ms; the worker counts the primes below it (the
// "heavy" work, never on the loop) and posts the result back to the loop, which publishes it:
//   {"label": "...", "below": 2000, "primes": 303}
// Log tags: PRIMES-START, PRIMES-STOP.
#include <skrobot/plugin.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace {

using skr::plugin::Host;

std::int64_t countPrimesBelow(std::int64_t limit) {
  std::int64_t count = 0;
  for (std::int64_t n = 2; n < limit; ++n) {
    bool prime = true;
    for (std::int64_t d = 2; d * d <= n && prime; ++d) prime = n % d != 0;
    count += prime ? 1 : 0;
  }
  return count;
}

class Primes final : public skr::plugin::Module {
 public:
  // The host has checked the config against kConfig below and filled in the defaults.
  explicit Primes(Host& host)
      : host_(host),
        label_(host.configString("label")),
        period_ns_(host.configInt("period_ms") * 1'000'000),
        step_(host.configInt("step")) {}

  void start() override {
    out_ = skr::plugin::StreamChannel(host_, "count", "application/json",
                                      R"({"description": "primes below a growing limit"})");
    next_ns_ = host_.nowNs() + period_ns_;
    tick_ = host_.onTick(skr::plugin::Tick::fast, [this] {
      const std::int64_t now = host_.nowNs();
      if (now < next_ns_ || !out_.hasSubscribers()) return;  // no work while nobody listens
      next_ns_ = now + period_ns_;
      std::lock_guard lock(mutex_);
      job_ = limit_ += step_;
      wake_.notify_one();
    });
    worker_ = std::thread([this] { work(); });
    host_.log.info("PRIMES-START", "label '", label_, "' on ", out_.name());
  }

  void stop() override {
    {
      std::lock_guard lock(mutex_);
      quit_ = true;
    }
    wake_.notify_one();
    if (worker_.joinable()) worker_.join();  // nothing posts after this
    tick_.reset();
    out_.reset();
    host_.log.info("PRIMES-STOP", published_, " results published");
  }

 private:
  void work() {
    std::unique_lock lock(mutex_);
    while (true) {
      wake_.wait(lock, [this] { return quit_ || job_.has_value(); });
      if (quit_) return;
      const std::int64_t below = *job_;
      job_.reset();
      lock.unlock();
      const std::int64_t primes = countPrimesBelow(below);
      host_.post([this, below, primes] { publish(below, primes); });  // back on the loop
      lock.lock();
    }
  }

  void publish(std::int64_t below, std::int64_t primes) {
    Json::Value v;
    v["label"] = label_;
    v["below"] = Json::Int64(below);
    v["primes"] = Json::Int64(primes);
    if (out_.publish(skr::support::writeJson(v))) ++published_;
  }

  Host& host_;
  const std::string label_;
  const std::int64_t period_ns_;
  const std::int64_t step_;
  skr::plugin::StreamChannel out_;
  skr::plugin::TickHandle tick_;
  std::int64_t next_ns_ = 0;
  std::uint64_t published_ = 0;  // loop thread only

  std::thread worker_;
  std::mutex mutex_;  // guards what follows
  std::condition_variable wake_;
  std::optional<std::int64_t> job_;
  std::int64_t limit_ = 0;
  bool quit_ = false;
};

}  // namespace

constexpr skr_config_key kConfig[] = {
    skr::config::string("label", "primes", "copied into every message"),
    skr::config::integer("period_ms", "500", "how often a new count starts, in milliseconds")
        .range(10, 60'000),
    skr::config::integer("step", "1000", "how much the limit grows each period")
        .range(1, 1'000'000),
};

SKROBOT_MODULE_WITH_CONFIG(Primes, "primes", "1.0.0",
                           "Counts primes on a worker thread and publishes the counts", 0, kConfig)
