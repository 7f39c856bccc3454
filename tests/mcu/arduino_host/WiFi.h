// SPDX-License-Identifier: Apache-2.0
// WiFi.h for the host (arduino_udp_test): the network is already up.
#ifndef SKR_HOST_WIFI_H
#define SKR_HOST_WIFI_H

#include <Arduino.h>

enum { WL_CONNECTED = 3 };

class HostWiFi {
 public:
  void begin(const char*, const char*) {}
  int status() { return WL_CONNECTED; }
};
extern HostWiFi WiFi;

#endif
