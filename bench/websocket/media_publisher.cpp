// SPDX-License-Identifier: Apache-2.0
// The camera of bench/websocket/video_page.mjs: a C++ satellite that publishes media frames
// (docs/channels.md) on one channel at a steady rate while it has subscribers.
//
//   ws_media_publisher ADDRESS NAME jpeg WIDTHxHEIGHT RATE_HZ FILE
//   ws_media_publisher ADDRESS NAME rgb8 WIDTHxHEIGHT RATE_HZ
//
// jpeg: the JPEG in FILE (WIDTHxHEIGHT its size, not checked here) in every frame; rgb8: a
// gradient of WIDTH x HEIGHT pixels. The channel "<user>.NAME" carries the encoding's mime type
// and properties (media_frame.hpp's vocabulary, plus width, height and fps), so the foxglove
// bridge shows it as CompressedImage or RawImage. Each frame's seq counts from 1 over the whole
// run, its capture_ns is CLOCK_MONOTONIC at publish. The account comes from ROBOT_USER and
// ROBOT_PASSWORD. Runs until SIGINT or SIGTERM, then prints "published N refused R": frames
// queued, and frames the satellite refused (its output full).
#include <skrobot/runtime/clock.h>
#include <skrobot/satellite.h>
#include <skrobot/media_frame.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>

namespace {

class Publisher : public skr::sat::Sketch {
 public:
  Publisher(skr::sat::SketchOptions o, skr::sat::ChannelSpec spec, skr::media::FrameHeader h,
            std::string frame)
      : Sketch(std::move(o)), spec_(std::move(spec)), header_(h), frame_(std::move(frame)) {}

  [[nodiscard]] uint64_t published() const noexcept { return published_; }
  [[nodiscard]] uint64_t refused() const noexcept { return refused_; }

 protected:
  void setup() override {
    if (auto r = satellite().addChannel(spec_); !r) {
      std::fprintf(stderr, "ws_media_publisher: %s\n", r.error().message.c_str());
      stop();
    }
  }
  // One frame per loop() (the sketch's absolute deadlines at RATE_HZ) while someone listens.
  void loop() override {
    if (!satellite().hasSubscribers(spec_.name)) return;
    header_.seq = published_ + refused_ + 1;
    header_.capture_ns = skr::monotonicNs();
    skr::media::writeHeader(header_, frame_.data());
    if (satellite().publish(spec_.name, frame_)) {
      ++published_;
    } else {
      ++refused_;
    }
  }

 private:
  skr::sat::ChannelSpec spec_;
  skr::media::FrameHeader header_;
  std::string frame_;  // header + payload; the header is rewritten for each frame
  uint64_t published_ = 0, refused_ = 0;
};

int usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s ADDRESS NAME jpeg WIDTHxHEIGHT RATE_HZ FILE\n"
               "       %s ADDRESS NAME rgb8 WIDTHxHEIGHT RATE_HZ\n",
               argv0, argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 6) return usage(argv[0]);
  const std::string format = argv[3];
  const bool jpeg = format == "jpeg";
  unsigned w = 0, hgt = 0;
  const double rate_hz = std::atof(argv[5]);
  if ((!jpeg && format != "rgb8") || argc != (jpeg ? 7 : 6) || rate_hz <= 0 ||
      std::sscanf(argv[4], "%ux%u", &w, &hgt) != 2 || w == 0 || hgt == 0 || w > 65535 ||
      hgt > 65535) {
    return usage(argv[0]);
  }

  skr::media::FrameHeader h;
  h.format = jpeg ? skr::media::Format::jpeg : skr::media::Format::rgb8;
  h.width = static_cast<uint16_t>(w);
  h.height = static_cast<uint16_t>(hgt);
  std::string payload;
  if (jpeg) {
    std::ifstream in(argv[6], std::ios::binary);
    payload.assign(std::istreambuf_iterator<char>(in), {});
    if (payload.size() < 4) {
      std::fprintf(stderr, "ws_media_publisher: cannot read a JPEG from %s\n", argv[6]);
      return 2;
    }
  } else {
    payload.resize(size_t(w) * hgt * 3);
    for (size_t y = 0; y < hgt; ++y) {
      for (size_t x = 0; x < w; ++x) {
        char* p = payload.data() + (y * w + x) * 3;
        p[0] = static_cast<char>(x * 255 / w);
        p[1] = static_cast<char>(y * 255 / hgt);
        p[2] = static_cast<char>((x + y) & 0xff);
      }
    }
  }
  const auto* info = skr::media::encodingInfo(h.format);

  ::setenv("ROBOT_ADDRESS", argv[1], 1);
  auto options = skr::sat::SketchOptions::fromEnvironment("ws_media_publisher");
  if (!options) {
    std::fprintf(stderr, "ws_media_publisher: %s\n", options.error().message.c_str());
    return 2;
  }
  options->rate_hz = rate_hz;
  // A raw 1280x720 frame is 2.7 MB: room for a few behind a slow hub before publish() refuses.
  options->satellite.max_queued_bytes = 32u << 20;

  skr::sat::ChannelSpec spec;
  spec.name = argv[2];
  spec.mime = std::string(info->mime);
  skr::flow::Variant::Map props;
  for (const auto& p : skr::media::channelProperties(*info)) {
    props[std::string(p.key)] = std::string(p.value);
  }
  props["width"] = int64_t{h.width};
  props["height"] = int64_t{h.height};
  props["fps"] = rate_hz;
  spec.props = std::move(props);

  std::string frame(skr::media::kHeaderBytes, '\0');
  frame += payload;
  Publisher p(std::move(options).value(), std::move(spec), h, std::move(frame));
  const int code = p.run();
  std::printf("published %llu refused %llu\n", static_cast<unsigned long long>(p.published()),
              static_cast<unsigned long long>(p.refused()));
  return code;
}
