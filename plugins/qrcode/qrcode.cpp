// qrcode: QR codes and barcodes in a video channel, published as JSON on <name>.codes:
//   {"seq","capture_ns","width","height",
//    "codes":[{"type":"QR-Code","text":"...","corners":[[x,y],[x,y],[x,y],[x,y]]}]}
// only when the set of codes changes, or again after config "repeat_ms" while codes stay in view.
// docs/vision.md lists the config keys.
#include "code_scanner.h"

#include <skrobot/vision/pipeline.h>

#include <memory>
#include <optional>

namespace {

using skr::vision::configFailure;

class QrCode final : public skr::plugin::Module {
 public:
  explicit QrCode(skr::plugin::Host& host) : host_(host) {
    repeat_ms_ = host.configInt("repeat_ms", 1000);
    if (repeat_ms_ < 0) configFailure(host, "repeat_ms", "must be >= 0 ms (0: every frame)");
    density_ = static_cast<int>(host.configInt("density", 2));
    if (density_ < 1 || density_ > 4) configFailure(host, "density", "must be 1..4");
    pipeline_.emplace(host, skr::vision::readPipelineOptions(host));
  }

  void start() override {
    out_ = skr::plugin::StreamChannel(
        host_, "codes", "application/json",
        R"({"source":)" + skr::vision::jsonString(pipeline_->options().input) + "}");
    pipeline_->start(
        [this]() -> skr::vision::Analyser {
          auto scanner = std::make_shared<skr::vision::CodeScanner>(density_);
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
    skr::vision::JsonWriter j;
    skr::vision::beginResult(j, in).key("codes").beginArray();
    for (const auto& c : codes) {
      j.beginObject().key("type").value(c.type).key("text").value(c.text).key("corners");
      j.beginArray();
      for (const auto& p : c.corners) j.beginArray().value(p.x).value(p.y).endArray();
      j.endArray().endObject();
    }
    j.endArray().endObject();
    return {in.header.seq, j.str(), skr::vision::codeSetKey(codes)};
  }

  skr::plugin::Host& host_;
  std::int64_t repeat_ms_ = 1000;
  int density_ = 2;
  std::optional<skr::vision::Pipeline> pipeline_;
  skr::plugin::StreamChannel out_;
  std::string last_key_;  // the set of codes last announced ("" = none)
  std::int64_t last_sent_ns_ = 0;
};

}  // namespace

SKROBOT_MODULE(QrCode, "qrcode", "1.0.0", "QR codes and barcodes on a video channel (zbar)", 0)
