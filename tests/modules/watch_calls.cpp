// SPDX-License-Identifier: Apache-2.0
// A C++ module on the watching calls (ABI 1.6, plugin_watch.hpp):
//   test_watch_calls.events  one line per event: "added <name> <kind> <mime>" and
//                            "removed <name>" for guest's channels, "set <key>=<json>",
//                            "del <key>" and "clear" for the database named by config "db"
// Messages on guest.cmd: "remove <key>" removes that key of the database (db_remove);
// "unwatch" ends both watches. Its own database "test_watch_calls" holds "hub" = the hub's name.
#include <skrobot/plugin_watch.hpp>

#include <string>

namespace {

class WatchCalls final : public skr::plugin::Module {
 public:
  explicit WatchCalls(skr::plugin::Host& host)
      : host_(host), db_(host.configString("db", "shared")) {}

  void start() override {
    events_ = skr::plugin::StreamChannel(host_, "events", "text/plain");
    const std::string hub = skr::plugin::hubName(host_);
    skr::plugin::dbSet(host_, "test_watch_calls", "hub", "\"" + hub + "\"");
    channels_ = skr::plugin::ChannelWatch(host_, [this](const skr::plugin::ChannelEvent& ev) {
      if (ev.name.rfind("guest.", 0) != 0) return;
      say(ev.added ? "added " + ev.name + " " + std::to_string(ev.kind) + " " + ev.mime
                   : "removed " + ev.name);
    });
    changes_ = skr::plugin::DatabaseWatch(
        host_, db_, [this](const std::string& key, const std::optional<std::string>& value) {
          if (key.empty() && !value) return say("clear");
          say(value ? "set " + key + "=" + *value : "del " + key);
        });
    cmd_ = skr::plugin::Subscription(host_, "guest.cmd", [this](std::string_view text) {
      if (text == "unwatch") {
        channels_.reset();
        changes_.reset();
      } else if (text.rfind("remove ", 0) == 0) {
        if (!skr::plugin::dbRemove(host_, db_, std::string(text.substr(7)))) say("remove failed");
      }
    });
  }
  void stop() override {
    cmd_.reset();
    changes_.reset();
    channels_.reset();
    events_ = {};
  }

 private:
  void say(const std::string& line) { events_.publish(line.data(), line.size()); }

  skr::plugin::Host& host_;
  std::string db_;
  skr::plugin::StreamChannel events_;
  skr::plugin::ChannelWatch channels_;
  skr::plugin::DatabaseWatch changes_;
  skr::plugin::Subscription cmd_;
};

}  // namespace

SKR_MODULE(WatchCalls, "test_watch_calls", "1.0.0", "watches channels and a database", 0)
