// motion: what moves in a video channel, published as JSON on <name>.motion:
//   {"seq","capture_ns","width","height","amount":0..1,"center":{"x","y"}|null,
//    "regions":[{"x","y","w","h"}]}
// docs/vision.md lists the config keys.
#include "motion_analyser.h"

#include <skrobot/vision/pipeline.h>

#include <memory>
#include <optional>

namespace {

using skr::vision::configFailure;

class Motion final : public skr::plugin::Module {
 public:
  explicit Motion(skr::plugin::Host& host) : host_(host), params_(readParams(host)) {
    // Motion compares each frame with the ones before: one worker sees them in order.
    pipeline_.emplace(host, skr::vision::readPipelineOptions(host, 1));
  }

  void start() override {
    out_ = skr::plugin::StreamChannel(
        host_, "motion", "application/json",
        R"({"source":)" + skr::vision::jsonString(pipeline_->options().input) + "}");
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
  static skr::vision::MotionParams readParams(skr::plugin::Host& host) {
    skr::vision::MotionParams p;
    p.method = host.configString("method", p.method);
    if (p.method != "diff" && p.method != "mog2") {
      configFailure(host, "method", "must be \"diff\" or \"mog2\", not \"" + p.method + "\"");
    }
    p.process_width = static_cast<int>(host.configInt("process_width", p.process_width));
    if (p.process_width != 0 && (p.process_width < 32 || p.process_width > 4096)) {
      configFailure(host, "process_width", "must be 0 (full size) or 32..4096 px");
    }
    p.threshold = static_cast<int>(host.configInt("threshold", p.threshold));
    if (p.threshold < 1 || p.threshold > 254) configFailure(host, "threshold", "must be 1..254");
    p.min_area = static_cast<int>(host.configInt("min_area", p.min_area));
    if (p.min_area < 0) configFailure(host, "min_area", "must be >= 0 px");
    p.min_amount = host.configDouble("min_amount", p.min_amount);
    if (!(p.min_amount >= 0 && p.min_amount <= 1))
      configFailure(host, "min_amount", "must be 0..1");
    p.history = static_cast<int>(host.configInt("history", p.history));
    if (p.history < 1) configFailure(host, "history", "must be >= 1 frame");
    return p;
  }

  static skr::vision::Outcome analyse(skr::vision::MotionAnalyser& analyser,
                                      const skr::vision::FrameIn& in) {
    const skr::vision::MotionResult r = analyser.analyse(in.image);
    skr::vision::JsonWriter j;
    skr::vision::beginResult(j, in).key("amount").value(r.amount).key("center");
    if (r.center) {
      j.beginObject().key("x").value(r.center->x).key("y").value(r.center->y).endObject();
    } else {
      j.null();
    }
    j.key("regions").beginArray();
    for (const auto& b : r.regions) {
      j.beginObject()
          .key("x")
          .value(b.x)
          .key("y")
          .value(b.y)
          .key("w")
          .value(b.width)
          .key("h")
          .value(b.height)
          .endObject();
    }
    j.endArray().endObject();
    return {in.header.seq, j.str(), {}};
  }

  skr::plugin::Host& host_;
  skr::vision::MotionParams params_;
  std::optional<skr::vision::Pipeline> pipeline_;
  skr::plugin::StreamChannel out_;
};

}  // namespace

SKROBOT_MODULE(Motion, "motion", "1.0.0", "moving regions and centre of motion on a video channel",
               0)
