// SPDX-License-Identifier: Apache-2.0
// The same as blob_files.c through plugin_blobs.hpp: the module's blob channel <name>.files and,
// once someone listens to <name>.report, one line per step ("bad:<status>", "put:<status>:...",
// "get:<status>:<data>", "list:<status>:<json>", "removed:<status>",
// "missing:<status>:<message>", "event:<status>:<json>" for each change of <name>.files).
#include <skrobot/plugin_blobs.hpp>
#include <skrobot/plugin_channels.hpp>

#include <string>

namespace {

using skr::plugin::BlobAnswer;

class BlobFilesCpp final : public skr::plugin::Module {
 public:
  explicit BlobFilesCpp(skr::plugin::Host& host) : host_(host) {}

  void start() override {
    using namespace skr::plugin;
    files_ = BlobChannel::own(host_, "files");
    report_ = StreamChannel(host_, "report", "text/plain", "{}", [this](bool first) {
      if (first) run();
    });
    changes_ = Subscription(host_, files_.name(), [this](std::string_view change) {
      say("event", BlobAnswer{SKR_OK, change, 0});
    });
  }
  void stop() override {
    changes_.reset();
    report_.reset();
  }

 private:
  void say(const std::string& what, const BlobAnswer& a, const std::string& extra = "") {
    report_.publish(what + ":" + std::to_string(a.status) + ":" + extra + std::string(a.data));
  }
  void run() {
    const bool refused =
        !files_.get("../x", 1024, [this](const BlobAnswer&) { report_.publish("never:called"); });
    report_.publish(std::string("bad:") + (refused ? "refused" : "accepted"));
    files_.put("a/hello.txt", "hello from a module", [this](const BlobAnswer& put) {
      report_.publish("put:" + std::to_string(put.status) + ":" +
                      (put.version != 0 ? "versioned" : "none"));
      files_.get("a/hello.txt", 1024, [this](const BlobAnswer& got) {
        say("get", got);
        files_.list("a", [this](const BlobAnswer& listed) {
          say("list", listed);
          files_.remove("a/hello.txt", [this](const BlobAnswer& removed) {
            report_.publish("removed:" + std::to_string(removed.status));
            files_.get("a/hello.txt", 1024,
                       [this](const BlobAnswer& missing) { say("missing", missing); });
          });
        });
      });
    });
  }

  skr::plugin::Host& host_;
  skr::plugin::BlobChannel files_;
  skr::plugin::StreamChannel report_;
  skr::plugin::Subscription changes_;
};

}  // namespace

SKR_MODULE(BlobFilesCpp, "test_blob_files_cpp", "1.0.0", "plugin_blobs.hpp in use", 0)
