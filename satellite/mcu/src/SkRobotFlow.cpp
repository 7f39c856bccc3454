// SPDX-License-Identifier: Apache-2.0
#include "SkRobotFlow.h"

int SkRobotFlow::read(void* ctx) {
  SkRobotFlow& f = *static_cast<SkRobotFlow*>(ctx);
  if (f.stash_count_ > 0) {  // what arrived first
    const uint8_t b = f.stash_[f.stash_head_];
    f.stash_head_ = (uint8_t)((f.stash_head_ + 1) % SKR_STASH);
    --f.stash_count_;
    return b;
  }
  return f.stream_.read();
}

void SkRobotFlow::drain() {
  while (stash_count_ < SKR_STASH && stream_.available() > 0) {
    stash_[(stash_head_ + stash_count_) % SKR_STASH] = (uint8_t)stream_.read();
    ++stash_count_;
  }
}

// What the stream takes without waiting goes at once; beyond it, one byte at a time, with what
// arrives meanwhile moved aside, so that a long frame out never costs the frames coming in.
void SkRobotFlow::write(void* ctx, const uint8_t* data, size_t n) {
  SkRobotFlow& f = *static_cast<SkRobotFlow*>(ctx);
  while (n > 0) {
    f.drain();
    const int room = f.stream_.availableForWrite();
    const size_t k = room > 0 ? ((size_t)room < n ? (size_t)room : n) : 1;
    f.stream_.write(data, k);
    data += k;
    n -= k;
  }
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
