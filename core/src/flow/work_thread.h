// SPDX-License-Identifier: Apache-2.0
// WorkThread: a thread of its own that runs jobs in the order they were given, for blocking work
// kept off the hub's loop (the blob store's disk work, a link's far blob reads). A job hands its
// result back itself (through the loop's post). Header-only: the blob store is also built into
// the fuzz targets, without the rest of the hub.
#pragma once

#include <pthread.h>
#include <sys/resource.h>
#include <unistd.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

namespace skr::flow {

class WorkThread {
 public:
  // What the jobs not started yet do when it stops: run first, or are dropped.
  enum class AtStop { finish, drop };

  // `name` (at most 15 characters shown, for top -H and perf); `nice`: its niceness (best
  // effort; 0 keeps the process's).
  WorkThread(std::string name, int nice, AtStop at_stop)
      : name_(std::move(name)), nice_(nice), at_stop_(at_stop) {}
  // Stops as start() said, after the job under way.
  ~WorkThread() { stop(); }
  WorkThread(const WorkThread&) = delete;
  WorkThread& operator=(const WorkThread&) = delete;

  // Jobs posted before run once it starts.
  void start() {
    if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
  }
  void post(std::function<void()> job) {
    {
      const std::lock_guard lock(mutex_);
      queue_.push_back(std::move(job));
    }
    cv_.notify_one();
  }
  void stop() noexcept {
    {
      const std::lock_guard lock(mutex_);
      stopping_ = true;
      if (at_stop_ == AtStop::drop) queue_.clear();
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void run() {
    if (nice_ != 0) (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), nice_);
    (void)::pthread_setname_np(::pthread_self(), name_.substr(0, 15).c_str());
    for (;;) {
      std::function<void()> job;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stopping, and nothing left to run
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      job();
    }
  }

  const std::string name_;
  const int nice_;
  const AtStop at_stop_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> queue_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace skr::flow
