// SPDX-License-Identifier: Apache-2.0
// The host calls of a module on its own thread (plugin ABI 1.10): each channel or database call
// runs on the hub's main loop thread while the module's thread waits for its status. A call is
// queued here and run by a task posted to the main loop, or, while the main thread waits for one
// of the module's lifecycle steps (init, start, stop, fini), by that wait itself: a module's
// start creates channels, and the main thread must not sit blocked while the module waits for
// it.
#pragma once

#include <skrobot/plugin.h>
#include <skrobot/runtime/loop.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>

namespace skr {

class ModuleCalls : public std::enable_shared_from_this<ModuleCalls> {
 public:
  explicit ModuleCalls(Loop& main) : main_(main) {}

  // The module's thread: runs `fn` on the main thread and returns what it returned.
  skr_status call(const std::function<skr_status()>& fn);
  // The main thread: runs `step` on `module_loop` and waits for it, running the module's calls
  // meanwhile.
  void runStep(Loop& module_loop, const std::function<void()>& step);

 private:
  struct Call {
    const std::function<skr_status()>* fn;
    skr_status status = SKR_OK;
    bool done = false;
  };
  // The main thread: runs the calls queued.
  void drain();

  Loop& main_;
  std::mutex mutex_;
  std::condition_variable cv_;  // a call queued, a call answered, a step done
  std::deque<Call*> queue_;
};

}  // namespace skr
