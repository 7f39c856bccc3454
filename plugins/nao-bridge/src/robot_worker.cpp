// SPDX-License-Identifier: Apache-2.0
#include "robot_worker.h"

#include "qi_client.h"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>

namespace skr::nao {

RobotWorker::RobotWorker(std::unique_ptr<RobotBackend> backend, WorkerOptions o, WorkerCallbacks cb)
    : backend_(std::move(backend)), opt_(o), cb_(std::move(cb)) {
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
}

RobotWorker::~RobotWorker() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void RobotWorker::start() {
  if (thread_.joinable()) return;
  stopping_ = false;
  thread_ = std::thread([this] { run(); });
}

void RobotWorker::stop() {
  stopping_ = true;
  wake();
  if (thread_.joinable()) thread_.join();
  for (Job& j : takeJobs()) {
    j.done(CommandResult::failure(CommandError::not_connected, "the bridge is stopping"));
  }
}

void RobotWorker::wake() {
  const std::uint64_t one = 1;
  if (wake_fd_ >= 0) (void)!::write(wake_fd_, &one, sizeof(one));
}

void RobotWorker::submit(Command c, RobotBackend::Done done) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    jobs_.push_back(Job{std::move(c), std::move(done), std::nullopt});
  }
  wake();
}

void RobotWorker::submitResult(CommandResult r, RobotBackend::Done done) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    jobs_.push_back(Job{Stop{}, std::move(done), std::move(r)});
  }
  wake();
}

void RobotWorker::setStreaming(StateKind k, bool on) {
  streaming_[static_cast<std::size_t>(k)] = on;
  wake();
}

std::deque<RobotWorker::Job> RobotWorker::takeJobs() {
  std::lock_guard<std::mutex> lock(mu_);
  return std::exchange(jobs_, {});
}

void RobotWorker::run() {
  using qi::monotonicNs;
  constexpr std::int64_t kMs = 1'000'000;
  int backoff_ms = opt_.reconnect_min_ms;
  std::int64_t next_attempt = 0;
  bool was_connected = false;
  // What the connected robot lacks, as last reported, and when to look for it again.
  std::map<std::string, std::string> missing;
  int missing_backoff_ms = opt_.reconnect_min_ms;
  std::int64_t next_missing_attempt = 0;
  auto reportConnected = [&](std::int64_t now) {
    const int in_ms =
        missing.empty()
            ? 0
            : static_cast<int>(std::max<std::int64_t>(0, (next_missing_attempt - now) / kMs));
    cb_.status(WorkerStatus{true, backend_->describe(), in_ms, missing});
  };
  std::array<std::int64_t, 5> next_read{};
  std::array<std::shared_ptr<bool>, 5> in_flight;
  for (auto& f : in_flight) f = std::make_shared<bool>(false);

  while (!stopping_) {
    std::uint64_t drained = 0;
    (void)!::read(wake_fd_, &drained, sizeof(drained));
    std::int64_t now = monotonicNs();
    if (!backend_->connected()) {
      for (Job& j : takeJobs()) {
        j.done(j.result ? *j.result
                        : CommandResult::failure(CommandError::not_connected,
                                                 "the robot is not connected"));
      }
      if (now >= next_attempt) {
        auto r = backend_->connect();
        if (r) {
          backoff_ms = opt_.reconnect_min_ms;
          was_connected = true;
          for (auto& f : in_flight) *f = false;
          missing = backend_->missing();
          missing_backoff_ms = opt_.reconnect_min_ms;
          now = monotonicNs();
          next_missing_attempt = now + missing_backoff_ms * kMs;
          reportConnected(now);
          continue;
        }
        cb_.status(WorkerStatus{false, r.error().message, backoff_ms, {}});
        next_attempt = monotonicNs() + backoff_ms * kMs;
        backoff_ms = std::min(backoff_ms * 2, opt_.reconnect_max_ms);
      }
      // Wait for the next attempt, a new job or stop (the backend has no socket to wait on).
      pollfd p{wake_fd_, POLLIN, 0};
      ::poll(
          &p, 1,
          static_cast<int>(std::clamp<std::int64_t>((next_attempt - monotonicNs()) / kMs, 0, 100)));
      continue;
    }
    for (Job& j : takeJobs()) {
      if (j.result) {
        j.done(*j.result);
      } else {
        backend_->execute(j.command, std::move(j.done));
      }
    }
    // Parts the robot lacks are looked for again with the reconnection backoff; one that goes
    // missing later (its process went away) starts again from the shortest delay.
    bool looked = false;
    if (!missing.empty() && now >= next_missing_attempt) {
      backend_->retryMissing();
      looked = true;
      missing_backoff_ms = std::min(missing_backoff_ms * 2, opt_.reconnect_max_ms);
      now = monotonicNs();
      next_missing_attempt = now + missing_backoff_ms * kMs;
    }
    if (backend_->connected()) {
      auto lacking = backend_->missing();
      if (lacking != missing || looked) {
        if (missing.empty() || lacking.empty()) {
          missing_backoff_ms = opt_.reconnect_min_ms;
          next_missing_attempt = now + missing_backoff_ms * kMs;
        }
        missing = std::move(lacking);
        reportConnected(now);
      }
    }
    std::int64_t wait_ns = 100 * kMs;
    if (!missing.empty()) {
      wait_ns = std::clamp<std::int64_t>(next_missing_attempt - now, 0, wait_ns);
    }
    for (std::size_t i = 0; i < next_read.size(); ++i) {
      if (!streaming_[i] || opt_.rate_hz[i] <= 0) continue;
      const auto period = static_cast<std::int64_t>(1e9 / opt_.rate_hz[i]);
      if (now >= next_read[i] && !*in_flight[i]) {
        // Absolute deadlines: no drift; after a stall, start again from now.
        next_read[i] = next_read[i] + period > now ? next_read[i] + period : now + period;
        *in_flight[i] = true;
        auto flag = in_flight[i];
        const auto kind = static_cast<StateKind>(i);
        backend_->read(kind, [this, flag, kind](Result<std::string> s) {
          *flag = false;
          if (s) cb_.state(kind, s.value());
        });
      }
      wait_ns = std::min(wait_ns, std::max<std::int64_t>(0, next_read[i] - now));
    }
    auto r = backend_->pump(static_cast<int>(wait_ns / kMs), wake_fd_);
    if (!r || !backend_->connected()) {
      const std::string why = r ? "disconnected" : r.error().message;
      backend_->disconnect(why);
      if (was_connected) cb_.status(WorkerStatus{false, why, backoff_ms, {}});
      was_connected = false;
      missing.clear();
      next_attempt = monotonicNs() + backoff_ms * kMs;
    }
  }
  backend_->disconnect("the bridge is stopping");
}

}  // namespace skr::nao
