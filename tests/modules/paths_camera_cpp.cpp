// SPDX-License-Identifier: Apache-2.0
// paths_camera.c through plugin_channels.hpp (StreamChannel::offerPaths, beginPublish,
// commitPublish): test_paths_camera_cpp.frames, shared memory and direct paths, one frame
// "frame <n> " and 2000 bytes of 'a' + n % 26 on each fast tick while subscribed, every other one
// filled in a slot in place.
#include <skrobot/plugin_channels.hpp>

#include <cstring>
#include <string>

namespace {

class PathsCameraCpp final : public skr::plugin::Module {
 public:
  explicit PathsCameraCpp(skr::plugin::Host& host) : host_(host) {}

  void start() override {
    frames_ = skr::plugin::StreamChannel(host_, "frames", "text/plain", "{}");
    frames_.offerPaths(SKR_PATH_SHM | SKR_PATH_DIRECT, 1 << 16);
    tick_ = host_.onTick(skr::plugin::Tick::fast, [this] { onTick(); });
  }
  void stop() override {
    tick_.reset();
    frames_.reset();
  }

 private:
  static std::string render(uint64_t n) {
    return "frame " + std::to_string(n) + " " + std::string(2000, char('a' + n % 26));
  }
  void onTick() {
    if (!frames_.hasSubscribers()) return;
    const std::string frame = render(++n_);
    if (n_ % 2 == 0) {
      auto slot = frames_.beginPublish();
      if (slot.size() >= frame.size()) {
        std::memcpy(slot.data(), frame.data(), frame.size());
        frames_.commitPublish(frame.size(), static_cast<int64_t>(n_));
        return;
      }
    }
    frames_.publish(frame);
  }

  skr::plugin::Host& host_;
  skr::plugin::StreamChannel frames_;
  skr::plugin::TickHandle tick_;
  uint64_t n_ = 0;
};

}  // namespace

SKR_MODULE(PathsCameraCpp, "test_paths_camera_cpp", "1.0.0", "plugin_channels.hpp paths", 0)
