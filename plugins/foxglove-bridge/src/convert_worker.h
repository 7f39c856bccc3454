// SPDX-License-Identifier: Apache-2.0
// A thread that runs conversions off the hub's loop thread (a camera frame's base64 takes about
// 1.3 ms for 315 KB). Two kinds of job: keyed ones, of which one waits per key (a channel) and a
// newer one replaces it, newest wins (images); and ordered ones, each run in turn, none replaced,
// at most kMaxOrderedBytes of them waiting (JSON messages, whose every one counts). The thread
// takes one of each kind by turns.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

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
      ordered_.clear();
      ordered_bytes_ = 0;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  static constexpr std::size_t kMaxOrderedBytes = 32u << 20;

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
  // Queues `job`, which holds `bytes` of data, behind the ordered jobs waiting; false (and
  // dropped) when they already hold kMaxOrderedBytes, or once stopped.
  bool submitInOrder(std::size_t bytes, std::function<void()> job) {
    {
      std::lock_guard lock(m_);
      if (stopping_ || ordered_bytes_ + bytes > kMaxOrderedBytes) return false;
      ordered_bytes_ += bytes;
      ordered_.emplace_back(bytes, std::move(job));
    }
    cv_.notify_one();
    return true;
  }

 private:
  void run() {
    std::unique_lock lock(m_);
    for (;;) {
      cv_.wait(lock, [this] { return stopping_ || !order_.empty() || !ordered_.empty(); });
      if (stopping_) return;
      std::function<void()> job;
      const bool keyed = !order_.empty() && (ordered_.empty() || !keyed_last_);
      keyed_last_ = keyed;
      if (keyed) {
        const std::uint32_t key = order_.front();
        order_.pop_front();
        job = std::move(jobs_.at(key));
        jobs_.erase(key);
      } else {
        ordered_bytes_ -= ordered_.front().first;
        job = std::move(ordered_.front().second);
        ordered_.pop_front();
      }
      lock.unlock();
      job();
      lock.lock();
    }
  }

  std::mutex m_;
  std::condition_variable cv_;
  std::map<std::uint32_t, std::function<void()>> jobs_;
  std::deque<std::uint32_t> order_;  // keys in the order their first waiting job came
  std::deque<std::pair<std::size_t, std::function<void()>>> ordered_;  // (bytes, job)
  std::size_t ordered_bytes_ = 0;
  bool keyed_last_ = false;  // which kind ran last
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace skr::foxglove
