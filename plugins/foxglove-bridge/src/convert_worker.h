// SPDX-License-Identifier: Apache-2.0
// A thread that runs conversions off the hub's loop thread (a camera frame's base64 takes about
// 1.3 ms for 315 KB): one job waits per key (a channel); a newer one replaces it, newest wins.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <thread>

namespace skr::foxglove {

class ConvertWorker {
 public:
  ConvertWorker() = default;
  ~ConvertWorker() { stop(); }
  ConvertWorker(const ConvertWorker&) = delete;
  ConvertWorker& operator=(const ConvertWorker&) = delete;

  void start() {
    std::lock_guard lock(m_);
    if (thread_.joinable()) return;
    stopping_ = false;
    thread_ = std::thread([this] { run(); });
  }
  // Joins the thread; jobs not started are dropped. Idempotent.
  void stop() {
    {
      std::lock_guard lock(m_);
      stopping_ = true;
      jobs_.clear();
      order_.clear();
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  // False when it replaced a job of `key` that had not started (that one is dropped).
  bool submit(std::uint32_t key, std::function<void()> job) {
    bool fresh = false;
    {
      std::lock_guard lock(m_);
      if (stopping_) return false;
      auto [it, inserted] = jobs_.insert_or_assign(key, std::move(job));
      fresh = inserted;
      if (inserted) order_.push_back(key);
    }
    cv_.notify_one();
    return fresh;
  }

 private:
  void run() {
    std::unique_lock lock(m_);
    for (;;) {
      cv_.wait(lock, [this] { return stopping_ || !order_.empty(); });
      if (stopping_) return;
      const std::uint32_t key = order_.front();
      order_.pop_front();
      std::function<void()> job = std::move(jobs_.at(key));
      jobs_.erase(key);
      lock.unlock();
      job();
      lock.lock();
    }
  }

  std::mutex m_;
  std::condition_variable cv_;
  std::map<std::uint32_t, std::function<void()>> jobs_;
  std::deque<std::uint32_t> order_;  // keys in the order their first waiting job came
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace skr::foxglove
