// SPDX-License-Identifier: Apache-2.0
// A supervised satellite's output: its standard output and error cut into lines, each kept in a
// bounded ring (flowctl logs) and written to the hub's log with the satellite's source
// ("sat.<name>") at most `lines_per_second` a second, so that a chatty child fills neither the
// hub's memory nor its disk. Loop thread only.
#pragma once

#include <skrobot/runtime/clock.h>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <string_view>
#include <vector>

namespace skr::supervisor {

struct LogLine {
  uint64_t seq = 0;     // 1, 2, ... for the satellite's whole life in this hub
  int64_t time_ms = 0;  // wall clock
  bool err = false;     // standard error
  std::string text;
};

class OutputLog {
 public:
  static constexpr size_t kMaxLineBytes = 4096;  // a longer line is cut, "[... N bytes cut]"
  static constexpr size_t kMaxLines = 2000;      // kept for flowctl logs
  static constexpr size_t kMaxBytes = 1 << 20;

  OutputLog(std::string source, uint32_t lines_per_second)
      : source_(std::move(source)), per_second_(lines_per_second) {}

  // Bytes read from the child's stdout (err false) or stderr: whole lines are taken.
  void received(bool err, std::string_view bytes);
  // The stream ended (the child exited): a last line without its newline is taken.
  void ended(bool err);
  // Ends a second (the supervisor's timer): says how many lines of it were not written to the
  // hub's log, and lets the next `lines_per_second` in.
  void everySecond();

  void setRate(uint32_t lines_per_second) noexcept { per_second_ = lines_per_second; }

  // Up to `max` lines after `seq` (the last `max` when there are more).
  [[nodiscard]] std::vector<LogLine> after(uint64_t seq, size_t max) const;
  [[nodiscard]] uint64_t lastSeq() const noexcept { return seq_; }
  [[nodiscard]] uint64_t notLogged() const noexcept { return not_logged_total_; }

 private:
  void take(bool err, std::string line);

  std::string source_;
  uint32_t per_second_;
  std::string partial_[2];  // stdout, stderr: the line being read
  size_t cut_[2] = {0, 0};  // bytes of it cut so far
  std::deque<LogLine> ring_;
  size_t ring_bytes_ = 0;
  uint64_t seq_ = 0;
  uint32_t in_window_ = 0;   // lines written to the log in it
  uint64_t not_logged_ = 0;  // lines of it not written
  uint64_t not_logged_total_ = 0;
};

}  // namespace skr::supervisor
