// SPDX-License-Identifier: Apache-2.0
// A C++ module on plugin_channels.hpp:
//   <name>.upper   streaming: what arrives on config "input" (default guest.in), upper-cased
//   <name>.ask     service: forwards each request to config "forward" (a service channel) with
//                  Requester and answers with {"forwarded": <the answer>} or {"error": ...};
//                  the command "sync" writes its value to key "synced" and answers "on disk"
//                  after a database barrier (plugin ABI 1.3)
// A reload that changes "input" alone is taken in place (reconfigure, ABI 1.11).
// With config "follow" (a sync source, plugin_sync.hpp) it publishes "pulse:<seq>:<dropped>" on
// <name>.upper for each pulse of that source and passes the pulse on to its own source
// <name>.tock: a chain in lockstep.
// It counts what it upper-cased in its database, key "count", and frames read with
// skr::media::parseFrame in key "media_seq".
#include <skrobot/media_frame.hpp>
#include <skrobot/plugin_channels.hpp>
#include <skrobot/plugin_sync.hpp>

#include <cctype>
#include <string>

namespace {

class ChannelsCpp final : public skr::plugin::Module {
 public:
  explicit ChannelsCpp(skr::plugin::Host& host)
      : host_(host),
        input_(host.configString("input", "guest.in")),
        forward_(host.configString("forward", "")),
        follow_(host.configString("follow", "")) {}

  void start() override {
    using namespace skr::plugin;
    upper_ = StreamChannel(host_, "upper", "text/plain", R"({"case":"upper"})");
    ask_ = ServiceChannel(host_, "ask", [this](const ServiceRequest& r) { onAsk(r); });
    requester_.emplace(host_);
    if (!follow_.empty()) {
      tock_ = SyncSource(host_, "tock");
      clock_ = SyncFollow(host_, follow_, [this](const Pulse& p) {
        upper_.publish("pulse:" + std::to_string(p.seq) + ":" + std::to_string(p.dropped));
        tock_.pulse();
      });
    }
    subscribeInput();
  }
  // ABI 1.11: a new "input" is followed in place (its channels stay, with their subscribers);
  // a change of anything else restarts it.
  bool reconfigure() override {
    if (host_.configString("forward", "") != forward_ ||
        host_.configString("follow", "") != follow_) {
      return false;
    }
    const std::string input = host_.configString("input", "guest.in");
    if (input != input_) {
      input_ = input;
      subscribeInput();
    }
    host_.log.info("RECONFIGURED", "input ", input_);
    return true;
  }
  void stop() override {
    clock_.reset();
    tock_.reset();
    in_.reset();
    requester_.reset();
    ask_.reset();
    upper_.reset();
  }

 private:
  void subscribeInput() {
    const std::string self(host_.name());
    in_ = skr::plugin::Subscription(host_, input_, [this, self](std::string_view payload) {
      if (auto frame = skr::media::parseFrame(payload)) {
        skr::plugin::dbSet(host_, self, "media_seq", std::to_string(frame->header.seq));
        return;
      }
      std::string text(payload);
      for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      upper_.publish(text);
      skr::plugin::dbSet(host_, self, "count", std::to_string(++count_));
      // A property of its channel, in the channel's database: subscribers get EV_CHAN_HEADER.
      skr::plugin::dbSet(host_, self + ".upper", "last_length", std::to_string(text.size()));
    });
  }

  void onAsk(const skr::plugin::ServiceRequest& r) {
    const uint64_t id = r.id;
    if (r.command == "sync") {  // a write, then a barrier: answered once both are on disk
      skr::plugin::dbSet(host_, std::string(host_.name()), "synced", r.value_json);
      const bool sent = skr::plugin::dbSync(
          host_, [this, id](bool ok) { ask_.respond(id, ok ? R"("on disk")" : R"("failed")"); });
      if (!sent) ask_.respond(id, R"("no barrier")");
      return;
    }
    const bool sent = requester_->request(
        forward_, r.command, r.value_json, [this, id](bool ok, const std::string& value) {
          ask_.respond(id, ok ? R"({"forwarded":)" + value + "}" : R"({"error":)" + value + "}");
        });
    if (!sent) ask_.respond(id, R"({"error":"no such channel"})");
  }

  skr::plugin::Host& host_;
  std::string input_;
  std::string forward_;
  std::string follow_;
  skr::plugin::SyncSource tock_;
  skr::plugin::SyncFollow clock_;
  skr::plugin::StreamChannel upper_;
  skr::plugin::ServiceChannel ask_;
  skr::plugin::Subscription in_;
  std::optional<skr::plugin::Requester> requester_;
  long count_ = 0;
};

}  // namespace

SKR_MODULE(ChannelsCpp, "test_channels_cpp", "1.0.0", "plugin_channels.hpp in use", 0)
