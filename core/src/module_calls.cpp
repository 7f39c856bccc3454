// SPDX-License-Identifier: Apache-2.0
#include "module_calls.h"

#include <utility>

namespace skr {

skr_status ModuleCalls::call(const std::function<skr_status()>& fn) {
  Call c{&fn};
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(&c);
  }
  cv_.notify_all();  // a lifecycle step's wait
  main_.post([weak = weak_from_this()] {
    if (auto self = weak.lock()) self->drain();
  });
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&c] { return c.done; });
  return c.status;
}

void ModuleCalls::drain() {
  std::deque<Call*> calls;
  {
    std::lock_guard lock(mutex_);
    calls.swap(queue_);
  }
  if (calls.empty()) return;  // the other drain took them
  for (Call* c : calls) {
    const skr_status status = (*c->fn)();
    std::lock_guard lock(mutex_);
    c->status = status;
    c->done = true;
  }
  cv_.notify_all();
}

void ModuleCalls::runStep(Loop& module_loop, const std::function<void()>& step) {
  bool done = false;
  module_loop.post([this, &step, &done] {
    step();
    {
      std::lock_guard lock(mutex_);
      done = true;
    }
    cv_.notify_all();
  });
  std::unique_lock lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this, &done] { return done || !queue_.empty(); });
    if (!queue_.empty()) {
      lock.unlock();
      drain();
      lock.lock();
      continue;
    }
    return;
  }
}

}  // namespace skr
