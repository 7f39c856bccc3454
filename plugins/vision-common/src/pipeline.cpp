// SPDX-License-Identifier: Apache-2.0
#include <skrobot/vision/decode.h>
#include <skrobot/vision/pipeline.h>

#include <algorithm>
#include <exception>
#include <utility>

namespace skr::vision {

void configFailure(plugin::Host& host, const char* key, const std::string& reason) {
  host.configError(key, reason);
  throw plugin::Failure(SKR_ERR_CONFIG, std::string("invalid config: ") + key + ": " + reason);
}

PipelineOptions readPipelineOptions(plugin::Host& host) {
  PipelineOptions o;
  o.input = host.configString("input");
  if (o.input.find('.') == std::string::npos) {
    configFailure(host, "input", "'" + o.input + "' is not a channel name (<owner>.<name>)");
  }
  o.workers = static_cast<int>(host.configInt("workers"));
  o.max_fps = host.configDouble("max_fps");
  return o;
}

Json::Value resultObject(const FrameIn& frame) {
  Json::Value v(Json::objectValue);
  v["seq"] = Json::UInt64(frame.header.seq);
  v["capture_ns"] = Json::Int64(frame.header.capture_ns);
  v["width"] = frame.image.cols;
  v["height"] = frame.image.rows;
  return v;
}

Pipeline::Pipeline(plugin::Host& host, PipelineOptions options)
    : host_(host), options_(std::move(options)), db_(host.name()) {}

Pipeline::~Pipeline() {
  stop();
}

void Pipeline::start(const AnalyserFactory& factory, Deliver deliver) {
  deliver_ = std::move(deliver);
  for (const char* key :
       {"frames", "processed", "skipped", "malformed", "limited", "late", "errors"}) {
    publishCounter(key, 0);
  }
  {
    std::lock_guard lock(mutex_);
    stopping_ = false;
  }
  for (int i = 0; i < options_.workers; ++i) {
    threads_.emplace_back(
        [this, analyse = factory()]() mutable { workerLoop(std::move(analyse)); });
  }
  sub_ = plugin::Subscription(host_, options_.input,
                              [this](std::string_view message) { onData(message); });
}

void Pipeline::stop() {
  sub_.reset();
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    slot_.reset();
  }
  wake_.notify_all();
  for (auto& t : threads_) t.join();
  threads_.clear();
}

void Pipeline::publishCounter(const char* key, std::int64_t value) {
  plugin::dbSet(host_, db_, key, std::to_string(value));
}

void Pipeline::onData(std::string_view message) {
  publishCounter("frames", ++counters_.frames);
  auto frame = media::parseFrame(message);
  if (!frame || frame->header.format == media::Format::pcm_s16le) {
    onMalformed();
    return;
  }
  if (options_.max_fps > 0) {
    // An absolute schedule, so that the average rate is max_fps whatever the input's jitter: a
    // frame up to a tenth of a period early is on time. After a pause the schedule restarts
    // from now instead of letting a burst through.
    const auto period_ns = static_cast<std::int64_t>(1e9 / options_.max_fps);
    const std::int64_t early_ns = period_ns / 10;
    const std::int64_t now = host_.nowNs();
    if (now + early_ns < next_accept_ns_) {
      publishCounter("limited", ++counters_.limited);
      return;
    }
    next_accept_ns_ = std::max(next_accept_ns_ + period_ns, now + period_ns - early_ns);
  }
  bool replaced = false;
  {
    std::lock_guard lock(mutex_);
    replaced = slot_.has_value();
    slot_ = Pending{arrivals_++, frame->header, std::string(frame->payload)};
  }
  wake_.notify_one();
  if (replaced) publishCounter("skipped", ++counters_.skipped);
}

void Pipeline::workerLoop(Analyser analyse) {
  for (;;) {
    Pending pending;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || slot_.has_value(); });
      if (stopping_) return;
      pending = std::move(*slot_);
      slot_.reset();
    }
    FrameIn in{pending.header, decodeFrame(pending.header, pending.payload, options_.pixels)};
    if (in.image.empty()) {
      host_.post([this] { onMalformed(); });
      continue;
    }
    in.header.width = static_cast<std::uint16_t>(in.image.cols);
    in.header.height = static_cast<std::uint16_t>(in.image.rows);
    Outcome out;
    try {
      out = analyse(in);
    } catch (const std::exception& e) {
      host_.post([this, what = std::string(e.what())] {
        publishCounter("errors", ++counters_.errors);
        host_.log.error("VISION-ANALYSE", "frame analysis failed: ", what);
      });
      continue;
    }
    out.seq = in.header.seq;
    // The host refuses posts once the module stops; the outcome is then dropped.
    host_.post([this, order = pending.order, out = std::move(out)]() mutable {
      onOutcome(order, std::move(out));
    });
  }
}

void Pipeline::onMalformed() {
  publishCounter("malformed", ++counters_.malformed);
}

void Pipeline::onOutcome(std::uint64_t order, Outcome&& outcome) {
  if (last_delivered_ && order < *last_delivered_) {
    publishCounter("late", ++counters_.late);
    return;
  }
  last_delivered_ = order;
  publishCounter("processed", ++counters_.processed);
  deliver_(std::move(outcome));
}

}  // namespace skr::vision
