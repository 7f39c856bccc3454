// SPDX-License-Identifier: Apache-2.0
// What SkRobotFlow (over a Stream) and SkRobotFlowUdp (over UDP) share: the session (skr_flow.h)
// and its calls. Not used on its own.
#ifndef SKROBOT_FLOW_BASE_H
#define SKROBOT_FLOW_BASE_H

#include <Arduino.h>

#include "skr_codes.h"
#include "skr_flow.h"

class SkRobotFlowBase {
 public:
  // A streaming channel <user>.<short_name>: its handle (>= 0), or -skr_status.
  int channel(const char* short_name, const char* mime) {
    return skr_channel(&flow_, short_name, mime);
  }
  // A service channel answered by `fn`.
  int service(const char* short_name, skr_service_fn fn, void* user = nullptr) {
    return skr_service_add(&flow_, short_name, fn, user);
  }
  // Subscriptions and sync sources by full name; declare them before the first poll().
  skr_status subscribe(const char* full_name, skr_data_fn fn, void* user = nullptr) {
    return skr_subscribe(&flow_, full_name, fn, user);
  }
  skr_status follow(const char* full_name, skr_pulse_fn fn, void* user = nullptr) {
    return skr_follow(&flow_, full_name, fn, user);
  }

  bool connected() const { return skr_connected(&flow_) != 0; }
  bool ready(int channel) const { return skr_channel_ready(&flow_, channel) != 0; }
  skr_status publish(int channel, const void* data, size_t n) {
    return skr_publish(&flow_, channel, data, n);
  }
  skr_status setVar(const char* key, int64_t v) { return skr_var_set_int64(&flow_, key, v); }
  skr_status setVar(const char* key, const char* s) { return skr_var_set_string(&flow_, key, s); }
  skr_status setVarFloat(const char* key, double v) { return skr_var_set_float64(&flow_, key, v); }
  // Reads `key` of database `db` (the board's own: its account's name); the value comes to `fn`
  // in a later poll() (read it with skr_value_*), a null pointer when the read failed.
  skr_status getVar(const char* db, const char* key, skr_value_fn fn, void* user = nullptr) {
    return skr_var_get(&flow_, db, key, fn, user);
  }
  const skr_stats& stats() { return *skr_get_stats(&flow_); }
  skr_flow& session() { return flow_; }

 protected:
  SkRobotFlowBase() = default;
  skr_flow flow_;
};

#endif  // SKROBOT_FLOW_BASE_H
