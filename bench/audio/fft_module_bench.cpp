// SPDX-License-Identifier: Apache-2.0
// fft-audio inside a hub: what a second of audio costs the whole process. A satellite publishes
// PCM (1024-sample frames) on guest.in as fast as the module keeps up and subscribes to
// fft.spectrum and fft.bands; the figure is the process CPU time (hub loop, module worker and the
// satellite's socket work together) per second of audio, next to the wall time.
//
//   fft_module_bench [--quick]
#include "test_client.h"

#include <skrobot/hub/flow/server.h>
#include <skrobot/hub/module_host.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/media_frame.hpp>

#include <json/json.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>

namespace {

namespace msg = skr::flow::msg;
using skr::flow::Code;
using skr::test::TestClient;

[[noreturn]] void fail(const std::string& why) {
  std::fprintf(stderr, "fft_module_bench: %s\n", why.c_str());
  std::exit(1);
}

double processCpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

std::string frame(std::uint64_t seq, std::size_t n) {
  std::string payload(n * 2, '\0');
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(seq + i) / 22050;
    const auto v = static_cast<std::uint16_t>(
        static_cast<std::int16_t>(8000 * std::sin(2 * std::numbers::pi * 440 * t)));
    payload[2 * i] = static_cast<char>(v & 0xff);
    payload[2 * i + 1] = static_cast<char>(v >> 8);
  }
  skr::media::FrameHeader h;
  h.format = skr::media::Format::pcm_s16le;
  h.seq = seq;
  h.channels = 1;
  h.sample_rate = 22050;
  return skr::media::makeFrame(h, payload);
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  const double seconds = quick ? 5 : 120;
  skr::log::setLevel(skr::log::Level::error);
  const auto dir =
      std::filesystem::temp_directory_path() / ("skrobot-fft-bench-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);

  skr::flow::ServerOptions so;
  so.app_name = "skrobot-bench-" + std::to_string(::getpid());
  so.unix_path = (dir / "hub.sock").string();
  so.data_dir = dir / "data";
  so.dev_account = std::make_pair(std::string("guest"), std::string("password"));
  auto hub = std::make_unique<skr::LoopThread>(skr::LoopOptions{});
  hub->start();
  std::unique_ptr<skr::flow::FlowServer> server;
  std::unique_ptr<skr::ModuleHost> modules;
  bool started = false;
  hub->loop().invoke([&] {
    server = std::make_unique<skr::flow::FlowServer>(hub->loop(), so);
    if (!server->start()) return;
    modules = std::make_unique<skr::ModuleHost>(hub->loop(), std::vector<std::filesystem::path>{},
                                                server.get());
    skr::ModuleEntry e;
    e.name = "fft";
    e.path = std::filesystem::path(SKROBOT_MODULE_DIR) / "fft-audio.so";
    e.config["input"] = "guest.in";
    e.config["queue_max"] = 1 << 20;  // keep every frame: the figure is per analysed second
    e.json_path = "$.modules[0]";
    modules->start({e});
    started = modules->failures().empty();
  });
  if (!started) fail("the hub or fft-audio did not start");

  auto sat = TestClient::connectUnix(so.unix_path);
  auto sync = TestClient::connectUnix(so.unix_path);
  if (!sat || !sync || !sat->loginFlow("guest", "password") || !sync->login("guest", "password")) {
    fail("cannot log in");
  }
  for (const char* name : {"fft.spectrum", "fft.bands"}) {
    auto info = skr::test::as<msg::ChannelInfoReply>(sync->call(msg::ChanInfoByName{name}));
    if (!info || !sat->send(msg::Subscribe{1, info->info.id})) fail(std::string("no ") + name);
  }
  msg::ChanAdd add;
  add.tag = 5;
  add.kind = 1;
  add.short_name = "in";
  add.mime = "audio/L16";
  add.props = skr::flow::Variant(skr::flow::Variant::Map{});
  sat->send(add);
  auto added = skr::test::as<msg::EvChanAdded>(sat->waitFor(Code::ev_chan_added));
  if (!added || !sat->waitFor(Code::ev_start_publish)) fail("cannot create guest.in");
  const std::uint16_t in = added->info.id;

  const auto total = static_cast<std::uint64_t>(seconds * 22050);
  const std::uint64_t windows = (total - 1024) / 512 + 1;
  std::uint64_t received = 0, bands = 0, sent = 0;
  const double cpu0 = processCpuSeconds();
  const auto wall0 = std::chrono::steady_clock::now();
  while (received < windows) {
    // Stay about a second of audio ahead of the analysis.
    while (sent < total && sent < received * 512 + 22050) {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(1024, total - sent));
      if (!sat->send(msg::Publish{in, msg::Rest{frame(sent, n)}})) fail("publish");
      sent += n;
    }
    auto data = skr::test::as<msg::EvData>(sat->waitFor(Code::ev_data, 30000));
    if (!data) fail("no results after " + std::to_string(received) + " windows");
    if (data->payload.bytes.find("\"bins\"") != std::string::npos) {
      ++received;
    } else {
      ++bands;
    }
  }
  const double cpu = processCpuSeconds() - cpu0;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  std::printf(
      "fft-audio in a hub: %.0f s of audio, size 1024, hop 512 (%llu spectra, %llu bands)\n",
      seconds, static_cast<unsigned long long>(received), static_cast<unsigned long long>(bands));
  std::printf("%22s %22s %18s\n", "process CPU ms/s audio", "% of a core at 1x",
              "x real time (wall)");
  std::printf("%22.2f %21.2f%% %18.0f\n", 1000 * cpu / seconds, 100 * cpu / seconds,
              seconds / wall);
  hub->loop().invoke([&] {
    modules.reset();
    server.reset();
  });
  hub.reset();
  std::filesystem::remove_all(dir);
  return 0;
}
