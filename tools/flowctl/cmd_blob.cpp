// SPDX-License-Identifier: Apache-2.0
// flowctl blob: the files of blob channels (docs/blob-channels.md), on the synchronous connection.
#include <unistd.h>

#include <cstdio>
#include <ctime>

#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

// A progress bar on a terminal's stderr for transfers of a few MB and more; nothing otherwise.
class ProgressBar {
 public:
  explicit ProgressBar(std::string what) : what_(std::move(what)), tty_(::isatty(2) == 1) {}
  ~ProgressBar() {
    if (shown_) std::fprintf(stderr, "\n");
  }
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  void operator()(uint64_t done, uint64_t total) {
    if (!tty_ || total < (4u << 20)) return;
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    const double t = double(now.tv_sec) + double(now.tv_nsec) / 1e9;
    if (start_ == 0) start_ = t;
    if (done < total && t - last_ < 0.1) return;
    last_ = t;
    shown_ = true;
    const int width = 30;
    const int filled = int(double(done) / double(total) * width);
    const double rate = t > start_ ? double(done) / (t - start_) / 1e6 : 0;
    std::fprintf(stderr, "\r%s [%.*s%*s] %5.1f%% %8.1f MB/s", what_.c_str(), filled,
                 "==============================", width - filled, "",
                 100.0 * double(done) / double(total), rate);
    std::fflush(stderr);
  }

 private:
  std::string what_;
  bool tty_;
  bool shown_ = false;
  double start_ = 0, last_ = 0;
};

// The blob channel CHANNEL ("<user>.<name>", or "<name>" for the caller's own).
std::optional<skr::sat::ChannelInfo> blobChannel(skr::sat::SyncClient& sync,
                                                 const std::string& name, bool create, int& code) {
  const std::string full =
      name.find('.') == std::string::npos ? sync.login().user + "." + name : name;
  auto info = sync.channel(full);
  const std::string prefix = sync.login().user + ".";
  if (!info && info.error().code == skr::Errc::not_found && create && full.rfind(prefix, 0) == 0) {
    info = sync.createBlobChannel(full.substr(prefix.size()));
  }
  if (!info) {
    code = fail(exitFor(info.error()), info.error().message);
    return std::nullopt;
  }
  if (info->kind != uint8_t(skr::flow::ChannelKind::blob)) {
    code = fail(kFailed, full + " is not a blob channel");
    return std::nullopt;
  }
  return std::move(info).value();
}

}  // namespace

int cmdBlob(const Cli& cli) {
  Args args(cli.args);
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() < 2) return usageError(cli);
  const std::string& verb = rest[0];
  const auto want = [&](size_t lo, size_t hi) { return rest.size() >= lo && rest.size() <= hi; };
  if ((verb == "ls" && !want(2, 3)) || (verb == "get" && !want(3, 4)) ||
      (verb == "put" && !want(4, 4)) ||
      ((verb == "mkdir" || verb == "rmdir" || verb == "rm") && !want(3, 3))) {
    return fail(kUsage, "wrong arguments for flowctl blob " + verb + " (see flowctl help blob)");
  }
  if (verb != "ls" && verb != "get" && verb != "put" && verb != "mkdir" && verb != "rmdir" &&
      verb != "rm") {
    return fail(kUsage, "unknown blob command '" + verb + "' (see flowctl help blob)");
  }
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto ch = blobChannel(*sync, rest[1], verb == "put", code);
  if (!ch) return code;
  const auto failed = [](const skr::Error& e) { return fail(exitFor(e), e.message); };

  if (verb == "ls") {
    auto list = sync->blobList(ch->id, rest.size() > 2 ? rest[2] : std::string());
    if (!list) return failed(list.error());
    if (cli.json) {
      Variant::List out;
      for (const auto& e : *list) {
        out.push_back(Variant::Map{{"name", e.name},
                                   {"dir", e.dir},
                                   {"size", e.size},
                                   {"mtime_ns", e.mtime_ns},
                                   {"version", e.version}});
      }
      std::printf("%s\n", skr::flow::variantToJsonText(out).c_str());
      return kOk;
    }
    for (const auto& e : *list) {
      char when[32] = "";
      const time_t secs = time_t(e.mtime_ns / 1000000000);
      tm t{};
      localtime_r(&secs, &t);
      std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", &t);
      std::printf("%12llu  %s  %s%s\n", static_cast<unsigned long long>(e.size), when,
                  e.name.c_str(), e.dir ? "/" : "");
    }
    return kOk;
  }
  if (verb == "get") {
    std::string local = rest.size() > 3 ? rest[3] : rest[2].substr(rest[2].rfind('/') + 1);
    ProgressBar bar("get " + rest[2]);
    if (local == "-") {
      auto data = sync->blobGet(ch->id, rest[2], std::ref(bar));
      if (!data) return failed(data.error());
      std::fwrite(data->data(), 1, data->size(), stdout);
      return kOk;
    }
    auto size = sync->blobGetFile(ch->id, rest[2], local, std::ref(bar));
    if (!size) return failed(size.error());
    return kOk;
  }
  if (verb == "put") {
    ProgressBar bar("put " + rest[3]);
    uint64_t size = 0;  // what was stored: the upload's size, as the last progress call says
    auto version = sync->blobPutFile(ch->id, rest[2], rest[3], [&](uint64_t done, uint64_t total) {
      size = total;
      bar(done, total);
    });
    if (!version) return failed(version.error());
    if (cli.json) {
      std::printf("%s\n", skr::flow::variantToJsonText(Variant::Map{{"channel", ch->name},
                                                                    {"path", rest[3]},
                                                                    {"size", size},
                                                                    {"version", *version}})
                              .c_str());
    } else {
      std::printf("stored %s as %s:%s, %llu bytes, version %llu\n", rest[2].c_str(),
                  ch->name.c_str(), rest[3].c_str(), static_cast<unsigned long long>(size),
                  static_cast<unsigned long long>(*version));
    }
    return kOk;
  }
  skr::Result<void> r = verb == "mkdir"   ? sync->blobMkdir(ch->id, rest[2])
                        : verb == "rmdir" ? sync->blobRmdir(ch->id, rest[2])
                                          : sync->blobRemove(ch->id, rest[2]);
  if (!r) return failed(r.error());
  return kOk;
}

}  // namespace flowctl
