// SPDX-License-Identifier: Apache-2.0
// Logging. A line carries UTC time, level, source and a stable tag that operators can search:
//   2026-11-22T10:00:00.123Z WARN  [core.loop] LOOP-OVERLOAD fast tick work 9.1 ms of 10 ms
// Thread-safe; each line is written with a single write(2).
#pragma once

#include <string>
#include <string_view>

namespace skr::log {

enum class Level { debug = 0, info = 1, warn = 2, error = 3 };

[[nodiscard]] std::string_view levelName(Level level) noexcept;
// Parses "debug", "info", "warn", "error"; false when unknown.
bool parseLevel(std::string_view text, Level& out) noexcept;

void setLevel(Level level) noexcept;
[[nodiscard]] Level level() noexcept;
[[nodiscard]] bool enabled(Level level) noexcept;

// Where lines go: a file descriptor (default 2, stderr).
void setFd(int fd) noexcept;

// Optional hook that sees every formatted line (tests use it to assert on logs). Not a sink for
// hot paths: it is called under the log lock.
using Hook = void (*)(Level level, std::string_view source, std::string_view tag,
                      std::string_view message, void* user);
void setHook(Hook hook, void* user) noexcept;

// Writes one line. `tag` may be empty for lines no operator searches for.
void write(Level level, std::string_view source, std::string_view tag, std::string_view message);

inline void debug(std::string_view src, std::string_view tag, std::string_view msg) {
  if (enabled(Level::debug)) write(Level::debug, src, tag, msg);
}
inline void info(std::string_view src, std::string_view tag, std::string_view msg) {
  write(Level::info, src, tag, msg);
}
inline void warn(std::string_view src, std::string_view tag, std::string_view msg) {
  write(Level::warn, src, tag, msg);
}
inline void error(std::string_view src, std::string_view tag, std::string_view msg) {
  write(Level::error, src, tag, msg);
}

}  // namespace skr::log
