// face-detect: the faces in each frame of a video channel, published as JSON on <name>.faces:
//   {"seq":N,"capture_ns":T,"width":W,"height":H,"faces":[{"x":..,"y":..,"w":..,"h":..,"score":..}]}
// An OpenCV cascade by default; YuNet (FaceDetectorYN) when config "model" names an ONNX file.
// docs/vision.md lists the config keys.
#include "face_detectors.h"

#include <skrobot/vision/pipeline.h>

#include <optional>
#include <stdexcept>

namespace {

using skr::vision::configFailure;

// Haar's frontalface_alt2: accurate (few false faces) at about 25 ms per 640x360 frame with the
// defaults below; lbpcascade_frontalface takes about a third of that (docs/vision.md).
constexpr const char* kDefaultCascade =
    "/usr/share/opencv4/haarcascades/haarcascade_frontalface_alt2.xml";

class FaceDetect final : public skr::plugin::Module {
 public:
  explicit FaceDetect(skr::plugin::Host& host) : host_(host), params_(readParams(host)) {
    auto options = skr::vision::readPipelineOptions(host);
    // Load once now, so that a bad file fails init with a clear message; workers load their own.
    try {
      const auto probe = skr::vision::makeFaceDetector(params_);
      options.pixels = probe->wantsColour() ? skr::vision::Pixels::bgr : skr::vision::Pixels::grey;
    } catch (const std::runtime_error& e) {
      configFailure(host, params_.model.empty() ? "cascade" : "model", e.what());
    }
    pipeline_.emplace(host, options);
  }

  void start() override {
    out_ = skr::plugin::StreamChannel(host_, "faces", "application/json",
                                      R"({"source":)" + skr::vision::jsonString(input()) + "}");
    pipeline_->start(
        [this]() -> skr::vision::Analyser {
          std::shared_ptr<skr::vision::FaceDetector> detector =
              skr::vision::makeFaceDetector(params_);
          return [detector](const skr::vision::FrameIn& in) { return analyse(*detector, in); };
        },
        [this](skr::vision::Outcome&& o) { out_.publish(o.payload); });
  }
  void stop() override {
    pipeline_->stop();
    out_.reset();
  }

 private:
  static skr::vision::FaceParams readParams(skr::plugin::Host& host) {
    skr::vision::FaceParams p;
    p.cascade = host.configString("cascade", kDefaultCascade);
    p.model = host.configString("model", "");
    p.scale_factor = host.configDouble("scale_factor", p.scale_factor);
    if (!(p.scale_factor > 1.0 && p.scale_factor <= 2.0)) {
      configFailure(host, "scale_factor", "must be > 1 and <= 2");
    }
    p.min_neighbors = static_cast<int>(host.configInt("min_neighbors", p.min_neighbors));
    if (p.min_neighbors < 0 || p.min_neighbors > 50) {
      configFailure(host, "min_neighbors", "must be 0..50");
    }
    p.min_size = static_cast<int>(host.configInt("min_size", p.min_size));
    if (p.min_size < 8 || p.min_size > 4096) configFailure(host, "min_size", "must be 8..4096 px");
    p.detect_width = static_cast<int>(host.configInt("detect_width", p.detect_width));
    if (p.detect_width != 0 && (p.detect_width < 64 || p.detect_width > 4096)) {
      configFailure(host, "detect_width", "must be 0 (full size) or 64..4096 px");
    }
    p.score_threshold = host.configDouble("score_threshold", p.score_threshold);
    if (!(p.score_threshold >= 0 && p.score_threshold <= 1)) {
      configFailure(host, "score_threshold", "must be 0..1");
    }
    p.nms_threshold = host.configDouble("nms_threshold", p.nms_threshold);
    if (!(p.nms_threshold >= 0 && p.nms_threshold <= 1)) {
      configFailure(host, "nms_threshold", "must be 0..1");
    }
    p.top_k = static_cast<int>(host.configInt("top_k", p.top_k));
    if (p.top_k < 1 || p.top_k > 5000) configFailure(host, "top_k", "must be 1..5000");
    return p;
  }

  static skr::vision::Outcome analyse(skr::vision::FaceDetector& detector,
                                      const skr::vision::FrameIn& in) {
    skr::vision::JsonWriter j;
    skr::vision::beginResult(j, in).key("faces").beginArray();
    for (const auto& f : detector.detect(in.image)) {
      j.beginObject()
          .key("x")
          .value(f.box.x)
          .key("y")
          .value(f.box.y)
          .key("w")
          .value(f.box.width)
          .key("h")
          .value(f.box.height)
          .key("score")
          .value(f.score)
          .endObject();
    }
    j.endArray().endObject();
    return {in.header.seq, j.str(), {}};
  }

  [[nodiscard]] const std::string& input() const { return pipeline_->options().input; }

  skr::plugin::Host& host_;
  skr::vision::FaceParams params_;
  std::optional<skr::vision::Pipeline> pipeline_;
  skr::plugin::StreamChannel out_;
};

}  // namespace

SKROBOT_MODULE(FaceDetect, "face-detect", "1.0.0",
               "faces on a video channel (OpenCV cascade or YuNet)", 0)
