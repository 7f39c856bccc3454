// SPDX-License-Identifier: Apache-2.0
// start() refuses. Its tick (registered in init) must never run; fini must still be called.
#include <skrobot/plugin.hpp>

namespace {

class StartFails final : public skr::plugin::Module {
 public:
  explicit StartFails(skr::plugin::Host& host)
      : host_(host),
        tick_(host.onTick(skr::plugin::Tick::fast, [this] { host_.log.info("STARTFAIL-TICK"); })) {}
  StartFails(const StartFails&) = delete;
  StartFails& operator=(const StartFails&) = delete;
  StartFails(StartFails&&) = delete;
  StartFails& operator=(StartFails&&) = delete;
  ~StartFails() override { host_.log.info("STARTFAIL-FINI", "destroyed"); }

  void start() override { throw skr::plugin::Failure(SKR_ERR_FAILED, "the motor is not powered"); }
  void stop() override { host_.log.info("STARTFAIL-STOP", "stop must not be called"); }

 private:
  skr::plugin::Host& host_;
  skr::plugin::TickHandle tick_;
};

}  // namespace

SKR_MODULE(StartFails, "start_fails", "0.1.0", "start fails", 0)
