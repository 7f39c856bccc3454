// SPDX-License-Identifier: Apache-2.0
#include "SkRobotFlow.h"

int SkRobotFlow::read(void* ctx) {
  return static_cast<SkRobotFlow*>(ctx)->stream_.read();
}

void SkRobotFlow::write(void* ctx, const uint8_t* data, size_t n) {
  static_cast<SkRobotFlow*>(ctx)->stream_.write(data, n);
}

uint32_t SkRobotFlow::clock(void*) {
  return millis();
}

void SkRobotFlow::begin(const char* user, const char* password, const char* client_name) {
  skr_io io;
  io.ctx = this;
  io.read = read;
  io.write = write;
  io.millis = clock;
  skr_init(&flow_, &io, user, password, client_name);
}
