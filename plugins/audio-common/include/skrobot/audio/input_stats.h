// SPDX-License-Identifier: Apache-2.0
// Writes a PcmInput's counters into the module's own database (keys frames, samples, malformed,
// gaps, gap_samples, format_changes) when they changed. Loop thread, from start() until stop().
#pragma once

#include <skrobot/audio/pcm_input.h>

#include <skrobot/plugin_channels.hpp>

#include <string>

namespace skr::audio {

class InputStats {
 public:
  void publish(const plugin::Host& host, const InputCounters& c, const std::string& prefix = "") {
    const std::string db(host.name());
    put(host, db, prefix + "frames", c.frames, last_.frames);
    put(host, db, prefix + "samples", c.samples, last_.samples);
    put(host, db, prefix + "malformed", c.malformed, last_.malformed);
    put(host, db, prefix + "gaps", c.gaps, last_.gaps);
    put(host, db, prefix + "gap_samples", c.gap_samples, last_.gap_samples);
    put(host, db, prefix + "format_changes", c.format_changes, last_.format_changes);
    initialised_ = true;
  }

 private:
  void put(const plugin::Host& host, const std::string& db, const std::string& key,
           std::uint64_t value, std::uint64_t& last) {
    if (initialised_ && value == last) return;
    plugin::dbSet(host, db, key, std::to_string(value));
    last = value;
  }
  InputCounters last_;
  bool initialised_ = false;
};

}  // namespace skr::audio
