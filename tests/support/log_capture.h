// SPDX-License-Identifier: Apache-2.0
// Collects the hub's log lines ("<tag> <message>") while alive, for tests that assert on logs.
#pragma once

#include <skrobot/runtime/log.h>

#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace skr::test {

// Collects log lines (tag + message) while alive.
class LogCapture {
 public:
  LogCapture() { log::setHook(&LogCapture::hook, this); }
  ~LogCapture() { log::setHook(nullptr, nullptr); }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;
  LogCapture(LogCapture&&) = delete;
  LogCapture& operator=(LogCapture&&) = delete;

  [[nodiscard]] bool sawTag(const std::string& tag) const {
    std::lock_guard lock(mutex_);
    for (const auto& l : lines_) {
      if (l.rfind(tag + " ", 0) == 0) return true;
    }
    return false;
  }
  [[nodiscard]] bool sawLine(const std::string& line) const {
    std::lock_guard lock(mutex_);
    for (const auto& l : lines_) {
      if (l == line) return true;
    }
    return false;
  }
  [[nodiscard]] std::vector<std::string> lines() const {
    std::lock_guard lock(mutex_);
    return lines_;
  }

 private:
  static void hook(log::Level, std::string_view, std::string_view tag, std::string_view msg,
                   void* user) {
    auto* self = static_cast<LogCapture*>(user);
    std::lock_guard lock(self->mutex_);
    self->lines_.push_back(std::string(tag) + " " + std::string(msg));
  }
  mutable std::mutex mutex_;
  std::vector<std::string> lines_;
};

}  // namespace skr::test
