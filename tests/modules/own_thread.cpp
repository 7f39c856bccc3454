// SPDX-License-Identifier: Apache-2.0
// Wants its own loop thread. Logs the id of the thread of every step (OWN-INIT, OWN-START,
// OWN-TICK once, OWN-STOP, OWN-FINI: message "<pthread id>") and what a tick_add from a foreign
// thread returned (OWN-FOREIGN "<status>").
#include <skrobot/plugin.hpp>

#include <pthread.h>

#include <cstdint>
#include <thread>

namespace {

std::uint64_t self() {
  return static_cast<std::uint64_t>(pthread_self());
}

class OwnThread final : public skr::plugin::Module {
 public:
  explicit OwnThread(skr::plugin::Host& host) : host_(host) {
    host_.log.info("OWN-INIT", self());
    tick_ = host_.onTick(skr::plugin::Tick::fast, [this] {
      if (ticks_++ == 0) host_.log.info("OWN-TICK", self());
    });
  }
  OwnThread(const OwnThread&) = delete;
  OwnThread& operator=(const OwnThread&) = delete;
  OwnThread(OwnThread&&) = delete;
  OwnThread& operator=(OwnThread&&) = delete;
  ~OwnThread() override { host_.log.info("OWN-FINI", self()); }

  void start() override {
    host_.log.info("OWN-START", self());
    std::thread([this] {
      skr_tick_handle h = 0;
      const skr_status st = host_.api()->tick_add(
          host_.ctx(), SKR_TICK_FAST, [](void*) {}, nullptr, &h);
      host_.log.info("OWN-FOREIGN", static_cast<int>(st));
    }).join();
  }
  void stop() override { host_.log.info("OWN-STOP", self()); }

 private:
  skr::plugin::Host& host_;
  skr::plugin::TickHandle tick_;
  int ticks_ = 0;
};

}  // namespace

SKR_MODULE(OwnThread, "own_thread", "0.1.0", "runs on its own loop thread",
           SKR_MODULE_WANTS_OWN_THREAD)
