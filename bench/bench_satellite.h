// SPDX-License-Identifier: Apache-2.0
// For the benchmarks that drive hubs through satellites (hub_link, nats_bridge, large_payload):
// polling for a condition, a hub in this process on a loop thread of its own, and a
// skr::sat::Satellite on a loop thread of its own. Header-only; the benchmark process stops
// (exit 1, a line on stderr) when a hub cannot start or a satellite cannot connect.
#pragma once

#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/satellite.h>

#include <errno.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>

namespace skr::bench {

// Polls `ready` every 2 ms for up to timeout_ms; its last answer.
template <class P>
bool waitFor(P&& ready, int timeout_ms = 10000) {
  const Nanos end = monotonicNs() + Nanos(timeout_ms) * kNsPerMs;
  while (!ready()) {
    if (monotonicNs() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

// A hub in this process on a loop thread of its own, on the Unix socket <dir>/<name>.sock with the
// development account (guest/password); `configure` adjusts its options first.
class InProcessHub {
 public:
  InProcessHub(const std::filesystem::path& dir, const std::string& name,
               const std::function<void(flow::ServerOptions&)>& configure = {}) {
    flow::ServerOptions so;
    so.app_name = "skrobot-bench-" + name + "-" + std::to_string(::getpid());
    so.unix_path = (dir / (name + ".sock")).string();
    so.dev_account = std::make_pair(std::string("guest"), std::string("password"));
    so.users_file = dir / (name + "-users.json");
    if (configure) configure(so);
    path_ = so.unix_path;
    thread_ = std::make_unique<LoopThread>(LoopOptions{.name = "hub " + name});
    thread_->start();
    Result<void> r;
    thread_->loop().invoke([&] {
      server_ = std::make_unique<flow::FlowServer>(thread_->loop(), so);
      r = server_->start();
    });
    if (!r) {
      std::fprintf(stderr, "%s: hub %s: %s\n", program_invocation_short_name, name.c_str(),
                   r.error().message.c_str());
      std::exit(1);
    }
  }
  ~InProcessHub() {
    thread_->loop().invoke([&] { server_.reset(); });
    thread_.reset();
  }
  InProcessHub(const InProcessHub&) = delete;
  InProcessHub& operator=(const InProcessHub&) = delete;

  [[nodiscard]] const std::string& path() const noexcept { return path_; }
  [[nodiscard]] sat::ConnectOptions connect(const std::string& client) const {
    sat::ConnectOptions o;
    o.address.kind = flow::Address::Kind::local;
    o.address.path = path_;
    o.client_name = client;
    o.timeout_ms = 30000;
    return o;
  }

 private:
  std::string path_;
  std::unique_ptr<LoopThread> thread_;
  std::unique_ptr<flow::FlowServer> server_;
};

// A Satellite on a loop thread of its own, started and connected when constructed. on(f) runs
// f(satellite) on that thread and returns its result; loop().post() queues work there.
class Sat {
 public:
  explicit Sat(const sat::ConnectOptions& connection, size_t max_queued_bytes = 32u << 20)
      : thread_(LoopOptions{.name = connection.client_name}) {
    thread_.start();
    sat::SatelliteOptions o;
    o.connection = connection;
    o.max_queued_bytes = max_queued_bytes;
    thread_.loop().invoke([&] {
      sat_ = std::make_unique<sat::Satellite>(thread_.loop(), o);
      sat_->start();
    });
    const auto connected = [&] {
      bool up = false;
      thread_.loop().invoke([&] { up = sat_->isConnected(); });
      return up;
    };
    if (!waitFor(connected, 30000)) {
      std::fprintf(stderr, "%s: %s cannot connect\n", program_invocation_short_name,
                   connection.client_name.c_str());
      std::exit(1);
    }
  }
  // A satellite named `client` on `hub` (anything with connect(client) -> sat::ConnectOptions).
  template <class H>
  Sat(const H& hub, const std::string& client) : Sat(hub.connect(client)) {}
  ~Sat() {
    thread_.loop().invoke([&] { sat_.reset(); });
    thread_.stop();
  }
  Sat(const Sat&) = delete;
  Sat& operator=(const Sat&) = delete;
  Sat(Sat&&) = delete;
  Sat& operator=(Sat&&) = delete;

  template <class F>
  auto on(F&& f) {
    using R = decltype(f(std::declval<sat::Satellite&>()));
    if constexpr (std::is_void_v<R>) {
      thread_.loop().invoke([&] { f(*sat_); });
    } else {
      R r{};
      thread_.loop().invoke([&] { r = f(*sat_); });
      return r;
    }
  }
  Loop& loop() { return thread_.loop(); }

 private:
  LoopThread thread_;
  std::unique_ptr<sat::Satellite> sat_;
};

// Whether `s` sees a channel of that full name now.
inline bool sees(Sat& s, const std::string& name) {
  return s.on([&](sat::Satellite& sat) { return sat.channel(name) != nullptr; });
}

}  // namespace skr::bench
