// SPDX-License-Identifier: Apache-2.0
#include "supervisor/output_log.h"

#include <skrobot/runtime/log.h>

namespace skr::supervisor {

void OutputLog::received(bool err, std::string_view bytes) {
  const int i = err ? 1 : 0;
  while (!bytes.empty()) {
    const size_t nl = bytes.find('\n');
    const std::string_view piece = bytes.substr(0, nl);
    const size_t room = kMaxLineBytes - std::min(kMaxLineBytes, partial_[i].size());
    partial_[i].append(piece.substr(0, room));
    cut_[i] += piece.size() - std::min(room, piece.size());
    if (nl == std::string_view::npos) return;
    bytes.remove_prefix(nl + 1);
    ended(err);
  }
}

void OutputLog::ended(bool err) {
  const int i = err ? 1 : 0;
  if (partial_[i].empty() && cut_[i] == 0) return;
  std::string line = std::move(partial_[i]);
  partial_[i].clear();
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (cut_[i] > 0) line += " [... " + std::to_string(cut_[i]) + " bytes cut]";
  cut_[i] = 0;
  take(err, std::move(line));
}

void OutputLog::take(bool err, std::string line) {
  if (in_window_ < per_second_) {
    ++in_window_;
    log::info(source_, err ? "SAT-STDERR" : "SAT-STDOUT", line);
  } else {
    ++not_logged_;
    ++not_logged_total_;
  }
  ring_bytes_ += line.size();
  ring_.push_back(LogLine{++seq_, realtimeNs() / kNsPerMs, err, std::move(line)});
  while (ring_.size() > kMaxLines || ring_bytes_ > kMaxBytes) {
    ring_bytes_ -= ring_.front().text.size();
    ring_.pop_front();
  }
}

void OutputLog::everySecond() {
  if (not_logged_ > 0) {
    log::warn(source_, "SAT-LOG-DROPPED",
              std::to_string(not_logged_) + " lines of output not written to the hub's log (more " +
                  "than " + std::to_string(per_second_) +
                  " a second; flowctl logs has the last ones)");
  }
  not_logged_ = 0;
  in_window_ = 0;
}

std::vector<LogLine> OutputLog::after(uint64_t seq, size_t max) const {
  std::vector<LogLine> out;
  for (const LogLine& l : ring_) {
    if (l.seq > seq) out.push_back(l);
  }
  if (out.size() > max) out.erase(out.begin(), out.end() - static_cast<std::ptrdiff_t>(max));
  return out;
}

}  // namespace skr::supervisor
