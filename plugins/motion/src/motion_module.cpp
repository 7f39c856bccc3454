// SPDX-License-Identifier: Apache-2.0
// motion: what moves in a video channel, published as JSON on <name>.motion:
//   {"seq","capture_ns","width","height","amount":0..1,"center":{"x","y"}|null,
//    "regions":[{"x","y","w","h"}]}
// docs/vision.md lists the config keys.
#include "motion_analyser.h"

#include <skrobot/vision/pipeline.h>
#include <skrobot/vision/result_types.h>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <memory>
#include <optional>

namespace {

using skr::vision::configFailure;

class Motion final : public skr::plugin::Module {
 public:
  explicit Motion(skr::plugin::Host& host) : host_(host), params_(readParams(host)) {
    // Motion compares each frame with the ones before: one worker sees them in order.
    pipeline_.emplace(host, skr::vision::readPipelineOptions(host));  // workers: 1 (kConfig)
  }

  void start() override {
    Json::Value props(Json::objectValue);
    props["source"] = pipeline_->options().input;
    skr::support::addTypeProperties(props, skr::vision::motionType());
    out_ = skr::plugin::StreamChannel(host_, "motion", "application/json",
                                      skr::support::writeJson(props));
    pipeline_->start(
        [this]() -> skr::vision::Analyser {
          auto analyser = std::make_shared<skr::vision::MotionAnalyser>(params_);
          return [analyser](const skr::vision::FrameIn& in) { return analyse(*analyser, in); };
        },
        [this](skr::vision::Outcome&& o) { out_.publish(o.payload); });
  }
  void stop() override {
    pipeline_->stop();
    out_.reset();
  }

 private:
  // Types, ranges and choices are declared in kConfig (checked by the host).
  static skr::vision::MotionParams readParams(skr::plugin::Host& host) {
    skr::vision::MotionParams p;
    p.method = host.configString("method");
    p.process_width = static_cast<int>(host.configInt("process_width"));
    if (p.process_width != 0 && p.process_width < 32) {
      configFailure(host, "process_width", "must be 0 (full size) or 32..4096 px");
    }
    p.threshold = static_cast<int>(host.configInt("threshold"));
    p.min_area = static_cast<int>(host.configInt("min_area"));
    p.min_amount = host.configDouble("min_amount");
    p.history = static_cast<int>(host.configInt("history"));
    return p;
  }

  static skr::vision::Outcome analyse(skr::vision::MotionAnalyser& analyser,
                                      const skr::vision::FrameIn& in) {
    const skr::vision::MotionResult r = analyser.analyse(in.image);
    Json::Value result = skr::vision::resultObject(in);
    result["amount"] = r.amount;
    Json::Value& center = result["center"];  // null when nothing moves enough
    if (r.center) {
      center["x"] = r.center->x;
      center["y"] = r.center->y;
    }
    Json::Value& regions = result["regions"] = Json::Value(Json::arrayValue);
    for (const auto& b : r.regions) {
      Json::Value box(Json::objectValue);
      box["x"] = b.x;
      box["y"] = b.y;
      box["w"] = b.width;
      box["h"] = b.height;
      regions.append(std::move(box));
    }
    return {in.header.seq, skr::support::writeJson(result), {}};
  }

  skr::plugin::Host& host_;
  skr::vision::MotionParams params_;
  std::optional<skr::vision::Pipeline> pipeline_;
  skr::plugin::StreamChannel out_;
};

}  // namespace

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    skr::vision::kInputKey,
    // Motion compares each frame with the ones before: one worker sees them in order.
    skr::vision::workersKey(1),
    skr::vision::kMaxFpsKey,
    cfg::string("method", "diff", "frame difference or a MOG2 background model").oneOf("diff|mog2"),
    cfg::integer("process_width", "320",
                 "frames are scaled to this width first; 0: full size, "
                 "else >= 32")
        .range(0, 4096),
    cfg::integer("threshold", "25", "grey-level change that counts as motion (MOG2: varThreshold)")
        .range(1, 254),
    cfg::integer("min_area", "100", "smallest region, pixels of the frame").min(0),
    cfg::number("min_amount", "0.002", "below this fraction of moving pixels, no centre")
        .range(0, 1),
    cfg::integer("history", "100", "MOG2: frames of history").min(1),
};

SKR_MODULE_WITH_CONFIG(Motion, "motion", "1.0.0",
                       "moving regions and centre of motion on a video channel", 0, kConfig)
