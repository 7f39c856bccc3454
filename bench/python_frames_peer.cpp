// SPDX-License-Identifier: Apache-2.0
// The C++ side of bench/python_frames.py: a publisher or a subscriber of bgr8 media frames, the
// baseline that the Python pairs are compared with in the same run.
//
//   python_frames_peer pub ADDRESS CHANNEL WIDTH HEIGHT RATE_HZ COUNT relay|shm
//     owns CHANNEL (shm: a ring of 4 slots of one frame, filled in place with beginPublish),
//     waits for a subscriber (shm: until its path serves it, 3 s at most), then publishes COUNT
//     frames at RATE_HZ (0: as fast as it can; a relayed publish() refused for a full output is
//     tried again at the next turn). Each frame's seq counts from 1, its capture_ns is
//     CLOCK_MONOTONIC when it was published. Prints "published N cpu_ns C" (this process's CPU from
//     the first frame to the last).
//   python_frames_peer sub ADDRESS NAME COUNT relay|shm QUEUE_BYTES SECONDS
//     subscribes to NAME (shm: asks for the path), and prints, after frame COUNT or SECONDS,
//     "received N skips S span_ns T lat_ns L1 L2 ..." (T: first to last receipt; skips: frames
//     missing before the last it got).
#include <skrobot/runtime/clock.h>
#include <skrobot/satellite.h>
#include <skrobot/media_frame.hpp>

#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

int64_t cpuNs() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return (int64_t(u.ru_utime.tv_sec) + u.ru_stime.tv_sec) * 1000000000 +
         (int64_t(u.ru_utime.tv_usec) + u.ru_stime.tv_usec) * 1000;
}

void header(char* out, uint64_t seq, uint16_t w, uint16_t h) {
  skr::media::FrameHeader fh;
  fh.format = skr::media::Format::bgr8;
  fh.seq = seq;
  fh.capture_ns = skr::monotonicNs();
  fh.width = w;
  fh.height = h;
  skr::media::writeHeader(fh, out);
}

class Publisher : public skr::sat::Sketch {
 public:
  Publisher(skr::sat::SketchOptions o, std::string channel, uint16_t w, uint16_t h, double rate,
            long count, bool shm)
      : Sketch(std::move(o)),
        channel_(std::move(channel)),
        w_(w),
        h_(h),
        period_ns_(rate > 0 ? int64_t(1e9 / rate) : 0),
        count_(count),
        frame_(skr::media::kHeaderBytes + size_t(w) * h * 3, '\x80') {
    spec_.name = channel_;
    spec_.mime = "video/x-raw";
    spec_.physical.shm = shm;
    spec_.physical.ring = {4, frame_.size(), 8};
    shm_ = shm;
  }

 protected:
  void setup() override {
    if (!satellite().addChannel(spec_)) stop();
  }
  void onStartPublish(uint16_t) override {
    if (!subscribed_) next_ns_ = skr::monotonicNs();
    subscribed_ = true;
  }
  void loop() override {
    const int64_t t = skr::monotonicNs();
    if (sent_ >= count_) {
      if (t - next_ns_ > 300'000'000) stop();  // what waits in the output went out meanwhile
      return;
    }
    if (!subscribed_ || t < next_ns_ - period_ns_ / 2) return;  // a tick may come early
    // A subscriber that asked for its path before our offer reached the hub asks again 1 s
    // later: shared memory starts once the path serves it (or after 3 s, relayed).
    if (sent_ == 0 && shm_ && satellite().pathStats().served_shm == 0 &&
        t < next_ns_ + 3'000'000'000) {
      return;
    }
    if (sent_ == 0) {
      cpu0_ = cpuNs();
      next_ns_ = t;  // the frames are due from now
    }
    if (shm_) {
      auto slot = satellite().beginPublish(channel_);
      if (slot.size() >= frame_.size()) {
        char* p = reinterpret_cast<char*>(slot.data());
        std::memcpy(p, frame_.data(), frame_.size());  // the camera's copy into the slot
        header(p, sent_ + 1, w_, h_);
        if (satellite().commitPublish(channel_, frame_.size(), 0)) ++sent_;
      }
    } else {
      header(frame_.data(), sent_ + 1, w_, h_);
      if (satellite().publish(channel_, frame_)) ++sent_;
    }
    if (period_ns_ > 0) next_ns_ += period_ns_;
    if (sent_ == count_) {
      std::printf("published %ld cpu_ns %lld\n", sent_, static_cast<long long>(cpuNs() - cpu0_));
      std::fflush(stdout);
      next_ns_ = t;
    }
  }

 private:
  std::string channel_;
  skr::sat::ChannelSpec spec_;
  uint16_t w_, h_;
  int64_t period_ns_, next_ns_ = 0;
  long count_, sent_ = 0;
  std::string frame_;
  bool shm_ = false, subscribed_ = false;
  int64_t cpu0_ = 0;
};

class Subscriber : public skr::sat::Sketch {
 public:
  Subscriber(skr::sat::SketchOptions o, std::string name, long count, bool shm, size_t queue,
             double seconds)
      : Sketch(std::move(o)),
        name_(std::move(name)),
        count_(count),
        shm_(shm),
        queue_(queue),
        end_(skr::monotonicNs() + int64_t(seconds * 1e9)) {}

 protected:
  void setup() override {
    if (shm_) satellite().usePaths(name_, skr::sat::kPathShm);
    satellite().subscribe(name_, queue_);
    satellite().dataView.connect(&satellite(), [this](uint16_t, std::string_view m) {
      const int64_t t = skr::monotonicNs();
      if (m.size() < skr::media::kHeaderBytes) return;
      uint64_t seq = 0;
      int64_t cap = 0;
      std::memcpy(&seq, m.data() + 8, 8);
      std::memcpy(&cap, m.data() + 16, 8);
      if (seq > last_ + 1) skips_ += long(seq - last_ - 1);  // seq counts from 1
      last_ = seq;
      if (lat_.empty()) first_ns_ = t;
      last_ns_ = t;
      lat_.push_back(t - cap);
    });
  }
  void loop() override {
    if (long(last_) >= count_ || skr::monotonicNs() > end_) {
      std::printf("received %zu skips %ld span_ns %lld lat_ns", lat_.size(), skips_,
                  static_cast<long long>(last_ns_ - first_ns_));
      for (int64_t l : lat_) std::printf(" %lld", static_cast<long long>(l));
      std::printf("\n");
      std::fflush(stdout);
      stop();
    }
  }

 private:
  std::string name_;
  long count_;
  bool shm_;
  size_t queue_;
  int64_t end_;
  uint64_t last_ = 0;
  long skips_ = 0;
  int64_t first_ns_ = 0, last_ns_ = 0;
  std::vector<int64_t> lat_;
};

}  // namespace

int main(int argc, char** argv) {
  const std::string role = argc > 1 ? argv[1] : "";
  if (!((role == "pub" && argc == 9) || (role == "sub" && argc == 8))) {
    std::fprintf(stderr,
                 "usage: %s pub ADDRESS CHANNEL WIDTH HEIGHT RATE_HZ COUNT relay|shm\n"
                 "       %s sub ADDRESS NAME COUNT relay|shm QUEUE_BYTES SECONDS\n",
                 argv[0], argv[0]);
    return 2;
  }
  ::setenv("ROBOT_ADDRESS", argv[2], 1);
  auto options = skr::sat::SketchOptions::fromEnvironment("python_frames_peer");
  if (!options) {
    std::fprintf(stderr, "%s\n", options.error().message.c_str());
    return 2;
  }
  if (role == "pub") {
    const double rate = std::atof(argv[6]);
    // loop() runs at RATE_HZ and publishes when a frame is due, or at 2 kHz and at every turn.
    options->rate_hz = rate > 0 ? rate : 2000;
    Publisher p(std::move(options).value(), argv[3], uint16_t(std::atoi(argv[4])),
                uint16_t(std::atoi(argv[5])), rate, std::atol(argv[7]),
                std::string(argv[8]) == "shm");
    return p.run();
  }
  options->rate_hz = 100;
  Subscriber s(std::move(options).value(), argv[3], std::atol(argv[4]),
               std::string(argv[5]) == "shm", std::strtoull(argv[6], nullptr, 10),
               std::atof(argv[7]));
  return s.run();
}
