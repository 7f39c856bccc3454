// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/log.h>

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <string>

namespace skr::log {
namespace {

std::atomic<Level> g_level{Level::info};
std::atomic<int> g_fd{2};
std::mutex g_mutex;
Hook g_hook = nullptr;
void* g_hook_user = nullptr;

void appendTime(std::string& out) {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  tm utc{};
  gmtime_r(&ts.tv_sec, &utc);
  char buf[40];
  const int n = std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03ldZ",
                              utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday, utc.tm_hour,
                              utc.tm_min, utc.tm_sec, ts.tv_nsec / 1'000'000);
  out.append(buf, static_cast<size_t>(n));
}

}  // namespace

std::string_view levelName(Level level) noexcept {
  switch (level) {
    case Level::debug:
      return "debug";
    case Level::info:
      return "info";
    case Level::warn:
      return "warn";
    case Level::error:
      return "error";
  }
  return "?";
}

bool parseLevel(std::string_view text, Level& out) noexcept {
  for (Level l : {Level::debug, Level::info, Level::warn, Level::error}) {
    if (text == levelName(l)) {
      out = l;
      return true;
    }
  }
  return false;
}

void setLevel(Level level) noexcept {
  g_level.store(level);
}
Level level() noexcept {
  return g_level.load();
}
bool enabled(Level l) noexcept {
  return static_cast<int>(l) >= static_cast<int>(g_level.load());
}
void setFd(int fd) noexcept {
  g_fd.store(fd);
}

void setHook(Hook hook, void* user) noexcept {
  std::lock_guard lock(g_mutex);
  g_hook = hook;
  g_hook_user = user;
}

void write(Level lvl, std::string_view source, std::string_view tag, std::string_view message) {
  if (!enabled(lvl)) return;
  static constexpr const char* kNames[] = {"DEBUG", "INFO ", "WARN ", "ERROR"};
  std::string line;
  line.reserve(64 + source.size() + tag.size() + message.size());
  appendTime(line);
  line += ' ';
  line += kNames[static_cast<int>(lvl)];
  line += " [";
  line += source;
  line += "] ";
  if (!tag.empty()) {
    line += tag;
    line += ' ';
  }
  line += message;
  line += '\n';
  std::lock_guard lock(g_mutex);
  const char* p = line.data();
  size_t left = line.size();
  while (left > 0) {
    const ssize_t n = ::write(g_fd.load(), p, left);
    if (n <= 0) break;  // nowhere to report a failing log sink
    p += n;
    left -= static_cast<size_t>(n);
  }
  if (g_hook != nullptr) g_hook(lvl, source, tag, message, g_hook_user);
}

}  // namespace skr::log
