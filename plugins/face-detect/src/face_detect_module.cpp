// SPDX-License-Identifier: Apache-2.0
// face-detect: the faces in each frame of a video channel, published as JSON on <name>.faces:
//   {"seq":N,"capture_ns":T,"width":W,"height":H,"faces":[{"x":..,"y":..,"w":..,"h":..,"score":..}]}
// An OpenCV cascade by default; YuNet (FaceDetectorYN) when config "model" names an ONNX file.
// docs/vision.md lists the config keys.
#include "face_detectors.h"

#include <skrobot/vision/pipeline.h>
#include <skrobot/vision/result_types.h>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

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
    Json::Value props(Json::objectValue);
    props["source"] = input();
    skr::support::addTypeProperties(props, skr::vision::facesType());
    out_ = skr::plugin::StreamChannel(host_, "faces", "application/json",
                                      skr::support::writeJson(props));
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
  // Types and ranges are declared in kConfig (checked by the host); only the rules a declaration
  // cannot express are checked here.
  static skr::vision::FaceParams readParams(skr::plugin::Host& host) {
    skr::vision::FaceParams p;
    p.cascade = host.configString("cascade");
    p.model = host.configString("model");
    p.scale_factor = host.configDouble("scale_factor");
    if (!(p.scale_factor > 1.0)) configFailure(host, "scale_factor", "must be > 1 and <= 2");
    p.min_neighbors = static_cast<int>(host.configInt("min_neighbors"));
    p.min_size = static_cast<int>(host.configInt("min_size"));
    p.detect_width = static_cast<int>(host.configInt("detect_width"));
    if (p.detect_width != 0 && p.detect_width < 64) {
      configFailure(host, "detect_width", "must be 0 (full size) or 64..4096 px");
    }
    p.score_threshold = host.configDouble("score_threshold");
    p.nms_threshold = host.configDouble("nms_threshold");
    p.top_k = static_cast<int>(host.configInt("top_k"));
    return p;
  }

  static skr::vision::Outcome analyse(skr::vision::FaceDetector& detector,
                                      const skr::vision::FrameIn& in) {
    Json::Value result = skr::vision::resultObject(in);
    Json::Value& faces = result["faces"] = Json::Value(Json::arrayValue);
    for (const auto& f : detector.detect(in.image)) {
      Json::Value face(Json::objectValue);
      face["x"] = f.box.x;
      face["y"] = f.box.y;
      face["w"] = f.box.width;
      face["h"] = f.box.height;
      face["score"] = f.score;
      faces.append(std::move(face));
    }
    return {in.header.seq, skr::support::writeJson(result), {}};
  }

  [[nodiscard]] const std::string& input() const { return pipeline_->options().input; }

  skr::plugin::Host& host_;
  skr::vision::FaceParams params_;
  std::optional<skr::vision::Pipeline> pipeline_;
  skr::plugin::StreamChannel out_;
};

}  // namespace

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    skr::vision::kInputKey,
    skr::vision::workersKey(8),
    skr::vision::kMaxFpsKey,
    cfg::string("cascade", kDefaultCascade, "OpenCV cascade file (used when model is empty)"),
    cfg::string("model", "", "YuNet ONNX model file; empty: use the cascade"),
    cfg::number("scale_factor", "1.2", "cascade: scale step between passes, > 1").range(1, 2),
    cfg::integer("min_neighbors", "3", "cascade: neighbours a face needs").range(0, 50),
    cfg::integer("min_size", "40", "smallest face, pixels of the frame").range(8, 4096),
    cfg::integer("detect_width", "320", "frames wider are scaled down first; 0: never, else >= 64")
        .range(0, 4096),
    cfg::number("score_threshold", "0.6", "YuNet: lowest face score").range(0, 1),
    cfg::number("nms_threshold", "0.3", "YuNet: non-maximum suppression overlap").range(0, 1),
    cfg::integer("top_k", "50", "YuNet: candidates kept before suppression").range(1, 5000),
};

SKR_MODULE_WITH_CONFIG(FaceDetect, "face-detect", "1.0.0",
                       "faces on a video channel (OpenCV cascade or YuNet)", 0, kConfig)
