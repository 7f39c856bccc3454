// SPDX-License-Identifier: Apache-2.0
// qrcode: QR codes and barcodes in a video channel, published as JSON on <name>.codes:
//   {"seq","capture_ns","width","height",
//    "codes":[{"type":"QR-Code","text":"...","corners":[[x,y],[x,y],[x,y],[x,y]]}]}
// only when the set of codes changes, or again after config "repeat_ms" while codes stay in view.
// docs/vision.md lists the config keys.
#include "code_scanner.h"

#include <skrobot/vision/pipeline.h>
#include <skrobot/vision/result_types.h>
#include <skrobot/support/json.hpp>
#include <skrobot/support/media_props.hpp>

#include <memory>
#include <optional>

namespace {

using skr::vision::configFailure;

class QrCode final : public skr::plugin::Module {
 public:
  explicit QrCode(skr::plugin::Host& host) : host_(host) {
    repeat_ms_ = host.configInt("repeat_ms");  // declared in kConfig, checked by the host
    density_ = static_cast<int>(host.configInt("density"));
    const auto types = skr::vision::codeTypesFromName(host.configString("types"));
    if (!types) configFailure(host, "types", "not one of the choices");  // the host checked them
    types_ = *types;
    pipeline_.emplace(host, skr::vision::readPipelineOptions(host));
  }

  void start() override {
    Json::Value props(Json::objectValue);
    props["source"] = pipeline_->options().input;
    skr::support::addTypeProperties(props, skr::vision::codesType());
    out_ = skr::plugin::StreamChannel(host_, "codes", "application/json",
                                      skr::support::writeJson(props));
    pipeline_->start(
        [this]() -> skr::vision::Analyser {
          auto scanner = std::make_shared<skr::vision::CodeScanner>(types_, density_);
          return [scanner](const skr::vision::FrameIn& in) { return analyse(*scanner, in); };
        },
        [this](skr::vision::Outcome&& o) { deliver(std::move(o)); });
  }
  void stop() override {
    pipeline_->stop();
    out_.reset();
  }

 private:
  // Loop thread: announce a new set of codes at once (an empty one too, so that viewers clear),
  // the same non-empty set again only every repeat_ms.
  void deliver(skr::vision::Outcome&& o) {
    const std::int64_t now = host_.nowNs();
    const bool changed = o.key != last_key_;
    const bool repeat = !o.key.empty() && now - last_sent_ns_ >= repeat_ms_ * 1'000'000;
    if (!changed && !repeat) return;
    last_key_ = std::move(o.key);
    last_sent_ns_ = now;
    out_.publish(o.payload);
  }

  static skr::vision::Outcome analyse(skr::vision::CodeScanner& scanner,
                                      const skr::vision::FrameIn& in) {
    const auto codes = scanner.scan(in.image);
    Json::Value result = skr::vision::resultObject(in);
    Json::Value& list = result["codes"] = Json::Value(Json::arrayValue);
    for (const auto& c : codes) {
      Json::Value code(Json::objectValue);
      code["type"] = c.type;
      code["text"] = c.text;
      Json::Value& corners = code["corners"] = Json::Value(Json::arrayValue);
      for (const auto& p : c.corners) {
        Json::Value point(Json::arrayValue);
        point.append(p.x);
        point.append(p.y);
        corners.append(std::move(point));
      }
      list.append(std::move(code));
    }
    return {in.header.seq, skr::support::writeJson(result), skr::vision::codeSetKey(codes)};
  }

  skr::plugin::Host& host_;
  std::int64_t repeat_ms_ = 1000;
  int density_ = 2;
  skr::vision::CodeTypes types_ = skr::vision::CodeTypes::common;
  std::optional<skr::vision::Pipeline> pipeline_;
  skr::plugin::StreamChannel out_;
  std::string last_key_;  // the set of codes last announced ("" = none)
  std::int64_t last_sent_ns_ = 0;
};

}  // namespace

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    skr::vision::kInputKey,
    skr::vision::workersKey(8),
    skr::vision::kMaxFpsKey,
    cfg::integer("repeat_ms", "1000",
                 "announce codes still in view again after this; 0: every "
                 "frame")
        .min(0),
    cfg::integer("density", "2", "zbar scans every density-th row and column (1: all)").range(1, 4),
    cfg::string("types", "common",
                "common: QR codes and the usual barcodes; qr: QR codes only; all: everything zbar "
                "reads, the EAN-2/5 add-ons and DataBar included (they misread ordinary pictures)")
        .oneOf(skr::vision::kCodeTypesChoices),
};

SKR_MODULE_WITH_CONFIG(QrCode, "qrcode", "1.0.0", "QR codes and barcodes on a video channel (zbar)",
                       0, kConfig)
