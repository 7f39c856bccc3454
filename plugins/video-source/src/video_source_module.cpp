// SPDX-License-Identifier: Apache-2.0
// video-source: publishes <name>.video, one JPEG media frame per message, from a video file
// (config "file", looped) or a V4L2 camera (config "device"), at config "fps" and
// "width" x "height". Frames are read only while the channel has subscribers.
// Its database "<name>" counts "frames" published and "loops" of the file.
#include "frame_reader.h"

#include <skrobot/vision/pipeline.h>
#include <skrobot/media_frame.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/support/config.hpp>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace {

using skr::vision::configFailure;

std::int64_t wallClockNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

class VideoSource final : public skr::plugin::Module {
 public:
  explicit VideoSource(skr::plugin::Host& host) : host_(host), params_(readParams(host)) {
    try {
      reader_ = std::make_unique<skr::vision::FrameReader>(params_);
    } catch (const std::runtime_error& e) {
      configFailure(host, params_.file.empty() ? "device" : "file", e.what());
    }
  }

  void start() override {
    Json::Value props(Json::objectValue);
    props["width"] = params_.width;
    props["height"] = params_.height;
    props["fps"] = params_.fps;
    const auto& jpeg = *skr::media::encodingInfo(skr::media::Format::jpeg);
    skr::support::addMediaProperties(props, jpeg);
    props["source"] = params_.file.empty() ? params_.device : params_.file;
    out_ = skr::plugin::StreamChannel(host_, "video", std::string(jpeg.mime),
                                      skr::support::writeJson(props), [this](bool first) {
                                        {
                                          std::lock_guard lock(mutex_);
                                          active_ = first;
                                        }
                                        wake_.notify_all();
                                      });
    offerPaths();
    db_ = std::string(host_.name());
    skr::plugin::dbSet(host_, db_, "frames", "0");
    skr::plugin::dbSet(host_, db_, "loops", "0");
    thread_ = std::thread([this] { run(); });
  }

  void stop() override {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
    out_.reset();
  }

 private:
  // Types and ranges are declared in kConfig (checked by the host); the rules a declaration
  // cannot express are checked here.
  static skr::vision::SourceParams readParams(skr::plugin::Host& host) {
    skr::vision::SourceParams p;
    p.file = host.configString("file");
    p.device = deviceName(host);
    if (p.file.empty() == p.device.empty()) {
      configFailure(host, p.file.empty() ? "file" : "device",
                    "give exactly one of \"file\" and \"device\"");
    }
    p.width = static_cast<int>(host.configInt("width"));
    if (p.width % 2 != 0) configFailure(host, "width", "must be an even number of pixels");
    p.height = static_cast<int>(host.configInt("height"));
    if (p.height % 2 != 0) configFailure(host, "height", "must be an even number of pixels");
    p.fps = host.configDouble("fps");
    if (!(p.fps > 0)) configFailure(host, "fps", "must be > 0 and <= 240");
    p.loop = host.configBool("loop");
    p.jpeg_quality = static_cast<int>(host.configInt("jpeg_quality"));
    return p;
  }

  // Config "paths" (plugin ABI 1.7): satellites on this machine may read the frames by shared
  // memory and/or a direct socket instead of the hub's relay. A slot holds a raw frame's worth
  // (4 bytes a pixel), more than any JPEG of it; a larger frame skips the ring, not the others.
  void offerPaths() {
    const std::string paths = host_.configString("paths");
    const std::uint32_t kinds = (paths.find("shm") != std::string::npos ? SKR_PATH_SHM : 0u) |
                                (paths.find("direct") != std::string::npos ? SKR_PATH_DIRECT : 0u);
    if (kinds == 0) return;
    const auto slot = static_cast<std::uint64_t>(params_.width) * params_.height * 4 + 4096;
    out_.offerPaths(kinds, slot);
  }

  // "device" may be a path ("/dev/video0") or an index (0 or "0"): declared as any value, so it
  // is read from the whole config object.
  static std::string deviceName(skr::plugin::Host& host) {
    if (!host.configHas("device")) return {};
    auto config = skr::support::parseJsonObject(host.configJson());
    if (!config) configFailure(host, "device", config.error().message);
    const Json::Value& d = (*config)["device"];
    if (d.isIntegral() && d.asInt64() >= 0) return std::to_string(d.asInt64());
    if (d.isString() && !d.asString().empty()) return d.asString();
    configFailure(host, "device", "must be a device path or a camera index >= 0");
  }

  // Reader thread: one frame per period on an absolute schedule, while someone subscribes.
  void run() {
    using Clock = std::chrono::steady_clock;
    const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / params_.fps));
    auto deadline = Clock::now();
    std::uint64_t seq = 0;
    bool ended = false;
    for (;;) {
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [this] { return stopping_ || active_; });
        if (stopping_) return;
        // Sleep to the deadline, waking early to stop.
        if (wake_.wait_until(lock, deadline, [this] { return stopping_; })) return;
        if (!active_) {
          deadline = Clock::now();
          continue;
        }
      }
      // After a stall (no subscribers, a slow read) restart the schedule instead of bursting.
      deadline = std::max(deadline + period, Clock::now() - period);
      if (ended) continue;
      bool looped = false;
      std::string jpeg = reader_->next(looped);
      if (jpeg.empty()) {
        ended = reader_->isFile();  // a file that does not loop; a camera may come back
        host_.post([this, file = reader_->isFile()] {
          host_.log.warn("VIDEO-SOURCE-EOF", file ? "end of the file" : "the camera gave no frame");
        });
        if (!ended) deadline += std::chrono::seconds(1);
        continue;
      }
      skr::media::FrameHeader h;
      h.format = skr::media::Format::jpeg;
      h.seq = seq++;
      h.capture_ns = wallClockNs();
      h.width = static_cast<std::uint16_t>(params_.width);
      h.height = static_cast<std::uint16_t>(params_.height);
      host_.post([this, frame = skr::media::makeFrame(h, jpeg), looped] {
        out_.publish(frame);
        skr::plugin::dbSet(host_, db_, "frames", std::to_string(++frames_));
        if (looped) skr::plugin::dbSet(host_, db_, "loops", std::to_string(++loops_));
      });
    }
  }

  skr::plugin::Host& host_;
  skr::vision::SourceParams params_;
  std::unique_ptr<skr::vision::FrameReader> reader_;  // the reader thread's, once started
  skr::plugin::StreamChannel out_;
  std::string db_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool active_ = false;  // the channel has subscribers
  bool stopping_ = false;
  // Loop thread.
  std::int64_t frames_ = 0;
  std::int64_t loops_ = 0;
};

}  // namespace

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    cfg::string("file", "",
                "a video file (or an image sequence such as img_%03d.png); "
                "give file or device"),
    cfg::any("device", nullptr, "a V4L2 camera: a device path or an index >= 0"),
    cfg::integer("width", "640", "frame width, even pixels").range(16, 7680),
    cfg::integer("height", "360", "frame height, even pixels").range(16, 4320),
    cfg::number("fps", "15", "frames per second, > 0").range(0, 240),
    cfg::boolean("loop", "true", "play the file again from the start when it ends"),
    cfg::integer("jpeg_quality", "80", "JPEG quality of the frames published").range(1, 100),
    cfg::string("paths", "none",
                "physical paths for satellites on this machine (docs/physical-mode.md): "
                "shared memory, a direct socket, both, or only the relay")
        .oneOf("none|shm|direct|shm+direct"),
};

SKR_MODULE_WITH_CONFIG(VideoSource, "video-source", "1.0.0",
                       "JPEG frames from a video file or a V4L2 camera", 0, kConfig)
