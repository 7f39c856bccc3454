// SPDX-License-Identifier: Apache-2.0
// C++ helpers over the blob channel calls of the plugin ABI (1.4; docs/blob-channels.md): files
// kept by the hub, written by their owner, read by everyone.
//
//   maps_ = skr::plugin::BlobChannel::own(host_, "maps");          // "<module>.maps"
//   maps_.put("floor1.pgm", bytes, [this](const skr::plugin::BlobAnswer& a) { ... });
//   if (auto calib = skr::plugin::BlobChannel::find(host_, "calibrator.files"))
//     calib->get("camera.yaml", 1 << 20, [this](const skr::plugin::BlobAnswer& a) { ... });
//
// Same rules as plugin_channels.hpp: the module's loop thread (the hub's main loop), from start()
// until stop(). Each call checks the channel and the path at once (false, logged by the host,
// and the callback is never called) or answers once through the callback on the loop thread;
// calls not answered when the module stops are answered SKR_ERR_BAD_STATE during its stop.
// A blob channel outlives the module: destroying a BlobChannel removes nothing.
#pragma once

#include <skrobot/plugin_channels.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace skr::plugin {

// The answer to one blob call.
struct BlobAnswer {
  skr_status status = SKR_OK;
  // get: the file's bytes; list: the entries as JSON text ([{"name", "dir", "size", "mtime_ns",
  // "version"}]); an error: its message. Valid during the callback only.
  std::string_view data;
  std::uint64_t version = 0;  // get, put: the file's version
  [[nodiscard]] bool ok() const noexcept { return status == SKR_OK; }
};

class BlobChannel {
 public:
  using AnswerFn = std::function<void(const BlobAnswer&)>;

  BlobChannel() = default;
  // The module's own blob channel "<module name>.<short name>", made or reopened with its files.
  static BlobChannel own(Host& host, const std::string& short_name) {
    requireBlobs(host);
    BlobChannel c(host, std::string(host.name()) + "." + short_name);
    detail::check(host,
                  host.api()->channel_create(host.ctx(), short_name.c_str(), SKR_CHANNEL_BLOB, "",
                                             nullptr, nullptr, nullptr, nullptr, &c.id_),
                  "channel_create " + short_name);
    return c;
  }
  // Another's blob channel by full name, to read; nullopt when it does not exist now.
  static std::optional<BlobChannel> find(Host& host, const std::string& full_name) {
    requireBlobs(host);
    BlobChannel c(host, full_name);
    if (host.api()->channel_find(host.ctx(), full_name.c_str(), &c.id_) != SKR_OK) {
      return std::nullopt;
    }
    return c;
  }

  // The whole current version of `path`, if it has at most `max_bytes`.
  bool get(const std::string& path, std::uint64_t max_bytes, AnswerFn fn) {
    return call(std::move(fn), false, [&](skr_blob_fn cb, void* user) {
      return host_->api()->blob_get(host_->ctx(), id_, path.c_str(), max_bytes, cb, user);
    });
  }
  // Replaces or creates `path` (and missing directories) with `data`, atomically (own channel).
  bool put(const std::string& path, std::string_view data, AnswerFn fn) {
    return call(std::move(fn), false, [&](skr_blob_fn cb, void* user) {
      return host_->api()->blob_put(host_->ctx(), id_, path.c_str(), data.data(), data.size(), cb,
                                    user);
    });
  }
  // The entries of directory `dir` ("" is the root) as JSON text.
  bool list(const std::string& dir, AnswerFn fn) {
    return call(std::move(fn), true, [&](skr_blob_fn cb, void* user) {
      return host_->api()->blob_list(host_->ctx(), id_, dir.c_str(), cb, user);
    });
  }
  bool mkdir(const std::string& path, AnswerFn fn) {
    return op(SKR_BLOB_MKDIR, path, std::move(fn));
  }
  bool rmdir(const std::string& path, AnswerFn fn) {
    return op(SKR_BLOB_RMDIR, path, std::move(fn));
  }
  bool remove(const std::string& path, AnswerFn fn) {
    return op(SKR_BLOB_REMOVE, path, std::move(fn));
  }

  [[nodiscard]] std::uint16_t id() const noexcept { return id_; }
  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  [[nodiscard]] bool valid() const noexcept { return host_ != nullptr; }

 private:
  BlobChannel(Host& host, std::string name)
      : host_(std::make_shared<Host>(host)), name_(std::move(name)) {}

  static void requireBlobs(const Host& host) {
    detail::requireAbi(host, 4, host.api()->blob_get != nullptr, "blob channel calls");
  }

  // One call in flight: its callback, freed when answered.
  struct Pending {
    std::shared_ptr<Host> host;
    AnswerFn fn;
    bool text;  // the data is NUL-terminated text (a list, or any error message)
  };
  static void answered(void* user, skr_status status, const void* data, std::size_t size,
                       std::uint64_t version) noexcept {
    std::unique_ptr<Pending> p(static_cast<Pending*>(user));
    std::string_view bytes(static_cast<const char*>(data), data != nullptr ? size : 0);
    if ((p->text || status != SKR_OK) && !bytes.empty() && bytes.back() == '\0') {
      bytes.remove_suffix(1);
    }
    detail::logged(p->host->api(), p->host->ctx(), "blob answer", [&] {
      p->fn(BlobAnswer{status, bytes, version});
    });
  }
  template <class Call>
  bool call(AnswerFn fn, bool text, Call&& c) {
    if (!host_) return false;
    auto p = std::make_unique<Pending>(Pending{host_, std::move(fn), text});
    if (c(&answered, p.get()) != SKR_OK) return false;  // refused at once: never answered
    (void)p.release();                                  // answered() frees it
    return true;
  }
  bool op(skr_blob_op what, const std::string& path, AnswerFn fn) {
    return call(std::move(fn), false, [&](skr_blob_fn cb, void* user) {
      return host_->api()->blob_do(host_->ctx(), id_, what, path.c_str(), cb, user);
    });
  }

  std::shared_ptr<Host> host_;
  std::uint16_t id_ = 0;
  std::string name_;
};

}  // namespace skr::plugin
