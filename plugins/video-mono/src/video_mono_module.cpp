// SPDX-License-Identifier: Apache-2.0
// video-mono: publishes <name>.mono, the Y8 (grey) variant of a JPEG video channel (config
// "input", required), decoded once for every module that wants grey pixels.
// It subscribes to the input only while <name>.mono has subscribers. Same counters as the
// detectors in its database "<name>" (frames, processed, skipped, malformed, ...).
#include <skrobot/vision/pipeline.h>
#include <skrobot/media_frame.hpp>
#include <skrobot/support/media_props.hpp>

#include <optional>

namespace {

class VideoMono final : public skr::plugin::Module {
 public:
  explicit VideoMono(skr::plugin::Host& host)
      : host_(host), options_(skr::vision::readPipelineOptions(host)) {}

  void start() override {
    Json::Value props(Json::objectValue);
    const auto& mono8 = *skr::media::encodingInfo(skr::media::Format::y8);
    skr::support::addMediaProperties(props, mono8);
    props["source"] = options_.input;
    // Start and stop at a later pulse, not inside the hub's subscribe call.
    out_ = skr::plugin::StreamChannel(
        host_, "mono", std::string(mono8.mime), skr::support::writeJson(props),
        [this](bool first) { host_.post([this, first] { setActive(first); }); });
  }
  void stop() override {
    if (pipeline_) pipeline_->stop();
    pipeline_.reset();
    out_.reset();
  }

 private:
  void setActive(bool active) {
    if (active == pipeline_.has_value()) return;
    if (!active) {
      pipeline_->stop();
      pipeline_.reset();
      return;
    }
    pipeline_.emplace(host_, options_);
    pipeline_->start(
        []() -> skr::vision::Analyser {
          return [](const skr::vision::FrameIn& in) {
            skr::media::FrameHeader h = in.header;
            h.format = skr::media::Format::y8;
            const auto* pixels = reinterpret_cast<const char*>(in.image.data);
            return skr::vision::Outcome{
                in.header.seq, skr::media::makeFrame(h, std::string_view(pixels, in.image.total())),
                std::to_string(h.width) + "x" + std::to_string(h.height)};
          };
        },
        [this](skr::vision::Outcome&& o) {
          if (o.key != size_) describe(o);
          out_.publish(o.payload);
        });
  }

  // The channel's database follows the frames: their size, and the input's nominal rate.
  void describe(const skr::vision::Outcome& o) {
    size_ = o.key;
    const std::string db = out_.name();
    const auto x = size_.find('x');
    skr::plugin::dbSet(host_, db, "width", size_.substr(0, x));
    skr::plugin::dbSet(host_, db, "height", size_.substr(x + 1));
    if (auto fps = skr::plugin::dbGet(host_, options_.input, "fps")) {
      skr::plugin::dbSet(host_, db, "fps", *fps);
    }
  }

  skr::plugin::Host& host_;
  skr::vision::PipelineOptions options_;
  std::optional<skr::vision::Pipeline> pipeline_;
  skr::plugin::StreamChannel out_;
  std::string size_;  // "WxH" of the last frame published
};

}  // namespace

constexpr skr_config_key kConfig[] = {skr::vision::kInputKey, skr::vision::workersKey(8),
                                      skr::vision::kMaxFpsKey};

SKR_MODULE_WITH_CONFIG(VideoMono, "video-mono", "1.0.0",
                       "the grey (Y8) variant of a JPEG video channel", 0, kConfig)
