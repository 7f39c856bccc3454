// video-source: publishes <name>.video, one JPEG media frame per message, from a video file
// (config "file", looped) or a V4L2 camera (config "device"), at config "fps" and
// "width" x "height". Frames are read only while the channel has subscribers.
// Its database "<name>" counts "frames" published and "loops" of the file.
#include "frame_reader.h"

#include <skrobot/vision/pipeline.h>
#include <skrobot/media_frame.hpp>
#include <skrobot/plugin_channels.hpp>

#include <json/json.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <sstream>
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
    skr::vision::JsonWriter props;
    props.beginObject()
        .key("width")
        .value(params_.width)
        .key("height")
        .value(params_.height)
        .key("fps")
        .value(params_.fps)
        .key("pixel_format")
        .value("yuvj420p")
        .key("codec")
        .value("jpeg")
        .key("source")
        .value(params_.file.empty() ? params_.device : params_.file)
        .endObject();
    out_ =
        skr::plugin::StreamChannel(host_, "video", "image/jpeg", props.str(), [this](bool first) {
          {
            std::lock_guard lock(mutex_);
            active_ = first;
          }
          wake_.notify_all();
        });
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
  static skr::vision::SourceParams readParams(skr::plugin::Host& host) {
    skr::vision::SourceParams p;
    p.file = host.configString("file", "");
    p.device = deviceName(host);
    if (p.file.empty() == p.device.empty()) {
      configFailure(host, p.file.empty() ? "file" : "device",
                    "give exactly one of \"file\" and \"device\"");
    }
    p.width = static_cast<int>(host.configInt("width", p.width));
    if (p.width < 16 || p.width > 7680 || p.width % 2 != 0) {
      configFailure(host, "width", "must be an even number of pixels, 16..7680");
    }
    p.height = static_cast<int>(host.configInt("height", p.height));
    if (p.height < 16 || p.height > 4320 || p.height % 2 != 0) {
      configFailure(host, "height", "must be an even number of pixels, 16..4320");
    }
    p.fps = host.configDouble("fps", p.fps);
    if (!(p.fps > 0 && p.fps <= 240)) configFailure(host, "fps", "must be > 0 and <= 240");
    p.loop = host.configBool("loop", p.loop);
    p.jpeg_quality = static_cast<int>(host.configInt("jpeg_quality", p.jpeg_quality));
    if (p.jpeg_quality < 1 || p.jpeg_quality > 100) {
      configFailure(host, "jpeg_quality", "must be 1..100");
    }
    return p;
  }

  // "device" may be a path ("/dev/video0") or an index (0 or "0").
  static std::string deviceName(skr::plugin::Host& host) {
    if (!host.configHas("device")) return {};
    Json::Value config;
    std::istringstream in(host.configJson());
    Json::CharReaderBuilder builder;
    std::string errors;
    if (!Json::parseFromStream(builder, in, &config, &errors)) return {};
    const Json::Value& d = config["device"];
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

SKROBOT_MODULE(VideoSource, "video-source", "1.0.0",
               "JPEG frames from a video file or a V4L2 camera", 0)
