// SPDX-License-Identifier: Apache-2.0
// Vision benchmark: latency from publishing a 640x360 JPEG frame to receiving its detection,
// for face-detect, motion and qrcode alone, then all three together, at the camera's 15 fps.
//
// The hub (FlowServer + ModuleHost) runs in this process on its own loop thread. A camera
// satellite publishes pre-encoded frames on guest.camera over the Unix socket on an absolute
// 15 fps schedule; one satellite per result channel records, for each result, the time since its
// frame was sent (two socket hops through the hub included). Frames are vtest.avi (walking
// people) with astronaut.png (a face) and a QR code pasted in, so every module has work;
// qrcode runs with repeat_ms 0 so that it answers every frame it analyses.
//
// Per module: results, p50/p99/max latency, frames analysed and skipped (db counters), and the
// process's CPU use over the run (hub, modules and satellites together; 100% = one core).
//
//   vision_latency [--quick] [--seconds S]
//
// Exits 1 on a real error (a module that fails to start or answers nothing); a missed target is
// reported, not an error.
#include "temp_dir.h"
#include "test_client.h"

#include <skrobot/hub/flow/server.h>
#include <skrobot/hub/module_host.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/media_frame.hpp>

#include <json/json.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
namespace flow = skr::flow;
namespace msg = skr::flow::msg;
using skr::test::TestClient;

constexpr double kFps = 15;
constexpr double kTargetP99Ms = 1000.0 / kFps;  // one frame period
constexpr const char* kVtest = "/usr/share/doc/opencv-doc/examples/data/vtest.avi";
constexpr const char* kAstronaut = "/usr/lib/python3/dist-packages/skimage/data/astronaut.png";

struct Fail : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  bool quick = false;
  double seconds = 20;
};

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      o.quick = true;
      o.seconds = 1.5;
    } else if (a == "--seconds" && i + 1 < argc) {
      o.seconds = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: vision_latency [--quick] [--seconds S]\n");
      std::exit(2);
    }
  }
  return o;
}

// --- frames ---------------------------------------------------------------------------------

std::vector<std::string> makeJpegs(const fs::path& tmp, int count) {
  cv::VideoCapture video(kVtest);
  const cv::Mat astronaut = cv::imread(kAstronaut);
  if (!video.isOpened() || astronaut.empty()) throw Fail("test data missing (opencv-doc, skimage)");
  const fs::path qr_png = tmp / "qr.png";
  const std::string cmd = "qrencode -s 4 -m 2 -o '" + qr_png.string() + "' 'skrobot vision bench'";
  if (std::system(cmd.c_str()) != 0) throw Fail("qrencode failed: " + cmd);
  const cv::Mat qr = cv::imread(qr_png.string());
  cv::Mat face;
  cv::resize(astronaut, face, cv::Size(300, 300), 0, 0, cv::INTER_AREA);
  std::vector<std::string> jpegs;
  cv::Mat bgr, frame;
  for (int i = 0; i < count && video.read(bgr); ++i) {
    cv::resize(bgr, frame, cv::Size(640, 360), 0, 0, cv::INTER_AREA);
    face.copyTo(frame(cv::Rect(330, 30, face.cols, face.rows)));
    qr.copyTo(frame(cv::Rect(10, 10, qr.cols, qr.rows)));
    std::vector<unsigned char> jpeg;
    cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80});
    jpegs.emplace_back(jpeg.begin(), jpeg.end());
  }
  return jpegs;
}

// --- one scenario ---------------------------------------------------------------------------

struct ModuleSpec {
  std::string name;     // in the config, and the owner of its channel
  std::string file;     // module file (<build>/modules/<file>.so)
  std::string channel;  // result channel, empty for video-mono
  std::string config;   // JSON
};

struct Row {
  std::string scenario, module;
  std::size_t results = 0;
  double p50 = 0, p99 = 0, max = 0;  // ms
  std::int64_t frames = 0, processed = 0, skipped = 0;
  double cpu = 0;  // % of one core, whole process
};

double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e6;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

class Scenario {
 public:
  Scenario(const fs::path& tmp, std::vector<ModuleSpec> modules)
      : tmp_(tmp), modules_(std::move(modules)) {
    flow::ServerOptions o;
    o.app_name = "skrobot-bench-vision";
    o.unix_path = (tmp_ / "hub.sock").string();
    o.data_dir = tmp_ / "data";
    o.dev_account = std::make_pair(std::string("guest"), std::string("password"));
    hub_ = std::make_unique<skr::LoopThread>(skr::LoopOptions{});
    hub_->start();
    skr::Result<void> started;
    hub_->loop().invoke([&] {
      server_ = std::make_unique<flow::FlowServer>(hub_->loop(), o);
      started = server_->start();
    });
    if (!started) throw Fail("hub: " + started.error().message);
  }
  ~Scenario() {
    hub_->loop().invoke([&] {
      host_.reset();
      server_.reset();
    });
    hub_.reset();
  }

  std::vector<Row> run(const std::string& name, const std::vector<std::string>& jpegs,
                       const Options& o) {
    startModules();
    TestClient camera = client(true);
    const std::uint16_t cam = addChannel(camera, "camera");
    if (!camera.waitFor(flow::Code::ev_start_publish, 20000)) throw Fail("no module subscribed");

    const int warmup = static_cast<int>(kFps * (o.quick ? 0.5 : 2.0));
    const int total = warmup + static_cast<int>(kFps * o.seconds);
    sent_ns_ = std::vector<std::atomic<std::int64_t>>(static_cast<std::size_t>(total));
    std::vector<std::unique_ptr<Reader>> readers;
    for (const auto& m : modules_) {
      if (!m.channel.empty()) {
        readers.push_back(std::make_unique<Reader>(*this, m.name + "." + m.channel, warmup));
      }
    }

    double cpu0 = 0;
    std::int64_t wall0 = 0;
    const auto period = static_cast<skr::Nanos>(1e9 / kFps);
    std::int64_t deadline = skr::monotonicNs();
    for (int seq = 0; seq < total; ++seq) {
      if (seq == warmup) {
        cpu0 = cpuSeconds();
        wall0 = skr::monotonicNs();
      }
      while (skr::monotonicNs() < deadline) {
        std::this_thread::sleep_for(std::chrono::nanoseconds(deadline - skr::monotonicNs()));
      }
      deadline += period;
      skr::media::FrameHeader h;
      h.seq = static_cast<std::uint64_t>(seq);
      h.width = 640;
      h.height = 360;
      const std::string frame = skr::media::makeFrame(h, jpegs[seq % jpegs.size()]);
      sent_ns_[static_cast<std::size_t>(seq)] = skr::monotonicNs();
      if (!camera.send(msg::Publish{cam, msg::Rest{frame}})) throw Fail("camera: send failed");
    }
    const double cpu =
        100.0 * (cpuSeconds() - cpu0) / (static_cast<double>(skr::monotonicNs() - wall0) / 1e9);
    std::this_thread::sleep_for(std::chrono::milliseconds(o.quick ? 500 : 1000));  // stragglers
    for (auto& r : readers) r->stop();

    TestClient sync = client(false);
    std::vector<Row> rows;
    std::size_t ri = 0;
    for (const auto& m : modules_) {
      Row row;
      row.scenario = name;
      row.module = m.name;
      row.frames = dbInt(sync, m.name, "frames");
      row.processed = dbInt(sync, m.name, "processed");
      row.skipped = dbInt(sync, m.name, "skipped") + dbInt(sync, m.name, "late") +
                    dbInt(sync, m.name, "limited");
      row.cpu = cpu;
      if (!m.channel.empty()) {
        const Reader& r = *readers[ri++];
        row.results = r.latencies_ms.size();
        row.p50 = percentile(r.latencies_ms, 0.50);
        row.p99 = percentile(r.latencies_ms, 0.99);
        row.max = percentile(r.latencies_ms, 1.0);
        if (row.results == 0) throw Fail(m.name + " published no result");
      }
      rows.push_back(row);
    }
    return rows;
  }

 private:
  // A satellite subscribed to one result channel, on its own thread.
  struct Reader {
    Reader(Scenario& s, const std::string& channel, int first_seq)
        : scenario(s), client(s.client(true)) {
      TestClient sync = s.client(false);
      auto info = skr::test::as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{channel}));
      if (!info) throw Fail("no channel " + channel);
      if (!client.send(msg::Subscribe{1, info->info.id})) throw Fail("subscribe " + channel);
      thread = std::thread([this, first_seq] { loop(first_seq); });
    }
    Reader(const Reader&) = delete;
    Reader& operator=(const Reader&) = delete;
    ~Reader() { stop(); }
    void stop() {
      done = true;
      if (thread.joinable()) thread.join();
    }
    void loop(int first_seq) {
      Json::CharReaderBuilder builder;
      std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
      while (!done) {
        auto data = skr::test::as<msg::EvData>(client.recv(100));
        if (!data) continue;
        const std::int64_t now = skr::monotonicNs();
        Json::Value v;
        const std::string_view text = data->payload.bytes;
        if (!reader->parse(text.data(), text.data() + text.size(), &v, nullptr)) continue;
        const auto seq = v["seq"].asUInt64();
        if (seq < static_cast<std::uint64_t>(first_seq) || seq >= scenario.sent_ns_.size())
          continue;
        latencies_ms.push_back(static_cast<double>(now - scenario.sent_ns_[seq]) / 1e6);
      }
    }
    Scenario& scenario;
    TestClient client;
    std::vector<double> latencies_ms;
    std::atomic<bool> done{false};
    std::thread thread;
  };

  void startModules() {
    std::vector<skr::ModuleEntry> entries;
    for (const auto& m : modules_) {
      skr::ModuleEntry e;
      e.name = m.name;
      e.path = fs::path(SKROBOT_MODULE_DIR) / (m.file + ".so");
      Json::CharReaderBuilder builder;
      std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
      if (!reader->parse(m.config.data(), m.config.data() + m.config.size(), &e.config, nullptr)) {
        throw Fail("bad config JSON for " + m.name);
      }
      e.json_path = "$.modules[" + std::to_string(entries.size()) + "]";
      entries.push_back(std::move(e));
    }
    std::string failed;
    hub_->loop().invoke([&] {
      host_ =
          std::make_unique<skr::ModuleHost>(hub_->loop(), std::vector<fs::path>{}, server_.get());
      host_->start(entries);
      for (const auto& f : host_->failures()) failed += f.name + ": " + f.reason + "; ";
    });
    if (!failed.empty()) throw Fail("modules failed: " + failed);
  }

  TestClient client(bool as_flow) {
    auto c = TestClient::connectUnix((tmp_ / "hub.sock").string());
    if (!c) throw Fail("connect: " + c.error().message);
    TestClient t = std::move(c).value();
    auto r = as_flow ? t.loginFlow("guest", "password") : t.login("guest", "password");
    if (!r) throw Fail("login: " + r.error().message);
    return t;
  }

  static std::uint16_t addChannel(TestClient& owner, const std::string& name) {
    msg::ChanAdd m;
    m.tag = 7;
    m.kind = static_cast<std::uint8_t>(flow::ChannelKind::streaming);
    m.short_name = name;
    m.mime = "image/jpeg";
    m.props = flow::Variant(flow::Variant::Map{});
    if (!owner.send(m)) throw Fail("chan add");
    auto ev = skr::test::as<msg::EvChanAdded>(owner.waitFor(flow::Code::ev_chan_added));
    if (!ev) throw Fail("no EV_CHAN_ADDED");
    return ev->info.id;
  }

  static std::int64_t dbInt(TestClient& sync, const std::string& db, const std::string& key) {
    auto sel = sync.call(msg::DbSelect{db});
    if (!sel || sel->kind() != flow::Code::reply_ok) return 0;
    auto v = skr::test::as<msg::ReplyValue>(sync.call(msg::VarGet{key}));
    return v ? v->value.asInt64().value_or(0) : 0;
  }

  fs::path tmp_;
  std::vector<ModuleSpec> modules_;
  std::unique_ptr<skr::LoopThread> hub_;
  std::unique_ptr<flow::FlowServer> server_;
  std::unique_ptr<skr::ModuleHost> host_;
  std::vector<std::atomic<std::int64_t>> sent_ns_;
};

// --- the table ------------------------------------------------------------------------------

void printRow(const Row& r, bool first_of_scenario) {
  const bool keeps_up = r.module == "mono" || (r.p99 < kTargetP99Ms && r.skipped == 0);
  std::printf("%-24s %-12s ", first_of_scenario ? r.scenario.c_str() : "", r.module.c_str());
  if (r.module == "mono") {
    std::printf("%7s %8s %8s %8s ", "-", "-", "-", "-");  // publishes frames, not results
  } else {
    std::printf("%7zu %8.1f %8.1f %8.1f ", r.results, r.p50, r.p99, r.max);
  }
  std::printf("%6lld/%-6lld %7lld ", static_cast<long long>(r.processed),
              static_cast<long long>(r.frames), static_cast<long long>(r.skipped));
  if (first_of_scenario) {
    std::printf("%6.0f%%", r.cpu);
  } else {
    std::printf("%7s", "");
  }
  std::printf("  %s\n", r.module == "mono" ? "-" : keeps_up ? "yes" : "NO");
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseOptions(argc, argv);
  std::signal(SIGPIPE, SIG_IGN);
  skr::log::setLevel(skr::log::Level::error);
  const skr::test::TempDir dir("skrobot-bench-vision");
  const fs::path& tmp = dir.path();
  int status = 0;
  try {
    const auto jpegs = makeJpegs(tmp, o.quick ? 30 : 150);
    const std::string in = R"({"input":"guest.camera"})";
    const std::string mono_in = R"({"input":"mono.mono"})";
    const ModuleSpec faces{"faces", "face-detect", "faces", in};
    const ModuleSpec motion{"motion", "motion", "motion", in};
    const ModuleSpec codes{"codes", "qrcode", "codes", R"({"input":"guest.camera","repeat_ms":0})"};
    const ModuleSpec mono{"mono", "video-mono", "", in};
    const std::vector<std::pair<std::string, std::vector<ModuleSpec>>> scenarios = {
        {"face-detect alone", {faces}},
        {"motion alone", {motion}},
        {"qrcode alone", {codes}},
        {"all three (own decode)", {faces, motion, codes}},
        {"all three on video-mono",
         {mono,
          {"faces", "face-detect", "faces", mono_in},
          {"motion", "motion", "motion", mono_in},
          {"codes", "qrcode", "codes", R"({"input":"mono.mono","repeat_ms":0})"}}},
        {"same, face-detect LBP",
         {mono,
          {"faces", "face-detect", "faces",
           R"({"input":"mono.mono","scale_factor":1.1,)"
           R"("cascade":"/usr/share/opencv4/lbpcascades/lbpcascade_frontalface.xml"})"},
          {"motion", "motion", "motion", mono_in},
          {"codes", "qrcode", "codes", R"({"input":"mono.mono","repeat_ms":0})"}}},
    };
    std::printf(
        "vision_latency: 640x360 JPEG (%zu B average) at %.0f fps for %.1f s per scenario "
        "(after a warm-up), %u cores\n"
        "latency: camera satellite send() -> result received by a satellite (through the hub)\n"
        "skipped: frames replaced by a newer one before a worker took them (+ late, limited)\n"
        "cpu: the whole process (hub, modules, satellites), 100%% = one core\n\n",
        [&] {
          std::size_t sum = 0;
          for (const auto& j : jpegs) sum += j.size();
          return sum / jpegs.size();
        }(),
        kFps, o.seconds, std::thread::hardware_concurrency());
    std::printf("%-24s %-12s %7s %8s %8s %8s %13s %7s %7s  %s\n", "scenario", "module", "results",
                "p50 ms", "p99 ms", "max ms", "analysed", "skipped", "cpu", "keeps up");
    for (const auto& [name, modules] : scenarios) {
      Scenario s(tmp, modules);
      bool first = true;
      for (const Row& r : s.run(name, jpegs, o)) {
        printRow(r, first);
        first = false;
      }
      std::fflush(stdout);
    }
    std::printf("\ntarget: p99 < %.1f ms (one frame period) and no skipped frame at %.0f fps\n",
                kTargetP99Ms, kFps);
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "vision_latency: error: %s\n", e.what());
    status = 1;
  }
  return status;
}
