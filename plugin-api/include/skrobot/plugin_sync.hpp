// SPDX-License-Identifier: Apache-2.0
// C++ helpers over the sync pulse of the plugin ABI (1.5; docs/sync-pulse.md): a source this
// module owns, and following a source so that its pulses drive the module's tick.
//
//   beat_ = skr::plugin::SyncSource(host_, "beat");          // beat_.pulse() on each cycle
//   clock_ = skr::plugin::SyncFollow(host_, "camera.frame_clock",
//                                    [this](const skr::plugin::Pulse& p) { step(p); });
//
// Same rules as plugin_channels.hpp: the module's loop thread (the hub's main loop), from start()
// until stop(); creation throws Failure, destruction unregisters.
#pragma once

#include <skrobot/plugin_channels.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>

namespace skr::plugin {

namespace detail {

inline void requireSync(const Host& host) {
  requireAbi(host, 5, host.api()->sync_follow != nullptr, "sync pulse calls");
}

}  // namespace detail

// A sync source this module owns, "<module name>.<short name>". Removed when destroyed.
class SyncSource {
 public:
  SyncSource() = default;
  SyncSource(Host& host, const std::string& short_name) : host_(std::make_unique<Host>(host)) {
    detail::requireSync(host);
    detail::check(host,
                  host.api()->channel_create(host.ctx(), short_name.c_str(), SKR_CHANNEL_SYNC, "",
                                             nullptr, nullptr, nullptr, nullptr, &id_),
                  "channel_create " + short_name);
    name_ = std::string(host.name()) + "." + short_name;
  }
  SyncSource(SyncSource&& other) noexcept { swap(other); }
  SyncSource& operator=(SyncSource&& other) noexcept {
    SyncSource(std::move(other)).swap(*this);
    return *this;
  }
  SyncSource(const SyncSource&) = delete;
  SyncSource& operator=(const SyncSource&) = delete;
  ~SyncSource() { reset(); }

  // One pulse to every follower that finished the previous one.
  bool pulse() noexcept { return host_ && host_->api()->sync_pulse(host_->ctx(), id_) == SKR_OK; }
  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  [[nodiscard]] bool valid() const noexcept { return host_ != nullptr; }

  void reset() noexcept {
    if (host_) host_->api()->channel_remove(host_->ctx(), id_);  // NOT_FOUND after stop
    host_.reset();
  }

 private:
  void swap(SyncSource& other) noexcept {
    std::swap(host_, other.host_);
    std::swap(id_, other.id_);
    std::swap(name_, other.name_);
  }

  std::unique_ptr<Host> host_;
  std::uint16_t id_ = 0;
  std::string name_;
};

// A pulse as the follower gets it.
struct Pulse {
  std::uint64_t seq = 0;             // the source's pulse count
  std::uint64_t source_time_ns = 0;  // the source's monotonic clock when it pulsed
  std::uint32_t dropped = 0;         // pulses dropped for this module since its last one
};

// Follows a sync source by full name (waiting for it, and again after it is re-created): the
// callback is the module's tick for each pulse, every `every`th one. The pulse is finished when
// the callback returns; with `done_later`, when done(seq) is called (after a worker's part, say),
// and pulses that come meanwhile are dropped for this module and counted in the next Pulse.
class SyncFollow {
 public:
  using PulseFn = std::function<void(const Pulse&)>;

  SyncFollow() = default;
  SyncFollow(Host& host, const std::string& source, PulseFn on_pulse, std::uint32_t every = 1,
             bool done_later = false)
      : state_(std::make_unique<State>(State{host, std::move(on_pulse)})) {
    detail::requireSync(host);
    detail::check(host,
                  host.api()->sync_follow(host.ctx(), source.c_str(), every,
                                          done_later ? SKR_SYNC_DONE_LATER : 0, &pulsed,
                                          state_.get(), &handle_),
                  "sync_follow " + source);
  }
  SyncFollow(SyncFollow&& other) noexcept { swap(other); }
  SyncFollow& operator=(SyncFollow&& other) noexcept {
    SyncFollow(std::move(other)).swap(*this);
    return *this;
  }
  SyncFollow(const SyncFollow&) = delete;
  SyncFollow& operator=(const SyncFollow&) = delete;
  ~SyncFollow() { reset(); }

  // With done_later: the tick for pulse `seq` is over.
  bool done(std::uint64_t seq) noexcept {
    return handle_ != 0 &&
           state_->host.api()->sync_done(state_->host.ctx(), handle_, seq) == SKR_OK;
  }
  void reset() noexcept {
    if (handle_ != 0) state_->host.api()->sync_unfollow(state_->host.ctx(), handle_);
    handle_ = 0;
    state_.reset();
  }
  [[nodiscard]] bool active() const noexcept { return handle_ != 0; }

 private:
  struct State {
    Host host;
    PulseFn on_pulse;
  };
  static void pulsed(void* user, std::uint16_t /*chan*/, std::uint64_t seq,
                     std::uint64_t source_time_ns, std::uint32_t dropped) noexcept {
    auto* s = static_cast<State*>(user);
    detail::logged(s->host.api(), s->host.ctx(), "pulse handler", [&] {
      s->on_pulse(Pulse{seq, source_time_ns, dropped});
    });
  }
  void swap(SyncFollow& other) noexcept {
    std::swap(state_, other.state_);
    std::swap(handle_, other.handle_);
  }

  std::unique_ptr<State> state_;
  skr_sub_handle handle_ = 0;
};

}  // namespace skr::plugin
