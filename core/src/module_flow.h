// SPDX-License-Identifier: Apache-2.0
// A module's satellite in the hub: the ABI 1.1 channel and database calls of one module, on top
// of a flow::LocalClient. Created by the module's first such call, destroyed when it stops (its
// channels and subscriptions go with it). Main loop thread only; a module on its own thread
// reaches it through ModuleCalls (module_calls.h) and gets its callbacks on its thread
// (deliverOn).
// Physical mode (ABI 1.7): the channels a module offers paths for are served by the owner side of
// the runtime's flow::phys::Paths (runtime/internal/paths.h), as a satellite's are, its Host
// bridged in-process to the hub's PhysicalPaths through the LocalClient instead of frames on a
// flow.
#pragma once

#include <skrobot/hub/flow/server.h>
#include <skrobot/plugin.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/loop.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace skr::flow::phys {
class Paths;
}

namespace skr {

class ModuleFlow {
 public:
  // What a module on its own thread may be behind by: data posted to its thread and not run yet.
  // Beyond it, messages for it are dropped (as a slow satellite's queue drops them).
  static constexpr size_t kMaxBehindBytes = size_t{64} << 20;

  ModuleFlow(flow::FlowServer& server, const std::string& module_name,
             std::shared_ptr<const flow::AccessRules> access);
  ~ModuleFlow();
  ModuleFlow(const ModuleFlow&) = delete;
  ModuleFlow& operator=(const ModuleFlow&) = delete;
  ModuleFlow(ModuleFlow&&) = delete;
  ModuleFlow& operator=(ModuleFlow&&) = delete;

  skr_status createChannel(const char* short_name, skr_channel_kind kind, const char* mime,
                           const char* props_json, skr_subscribers_fn on_subscribers,
                           skr_request_fn on_request, void* user, uint16_t* chan_id_out);
  skr_status removeChannel(uint16_t chan_id);
  skr_status findChannel(const char* name, uint16_t* chan_id_out) const;
  skr_status publish(uint16_t chan_id, const void* data, size_t size);
  skr_status publishRetained(uint16_t chan_id, const char* key, const void* data, size_t size);
  skr_status retainClear(uint16_t chan_id, const char* key);
  skr_status subscribe(const char* name, skr_data_fn fn, void* user, skr_sub_handle* handle_out);
  skr_status unsubscribe(skr_sub_handle handle);
  skr_status request(uint16_t chan_id, uint32_t tag, const char* command, const char* value_json,
                     skr_response_fn fn, void* user);
  skr_status respond(uint16_t chan_id, uint64_t request, const char* value_json);
  skr_status dbGet(const char* db, const char* key, char* buf, size_t cap, size_t* len_out);
  skr_status dbSet(const char* db, const char* key, const char* value_json);
  skr_status dbSync(skr_done_fn fn, void* user);
  skr_status dbRemove(const char* db, const char* key);
  skr_status dbWatch(const char* db, skr_db_change_fn fn, void* user, skr_sub_handle* handle_out);
  skr_status dbUnwatch(skr_sub_handle handle);
  skr_status channelWatch(skr_channel_fn fn, void* user, skr_sub_handle* handle_out);
  skr_status channelUnwatch(skr_sub_handle handle);
  skr_status blobGet(uint16_t chan_id, const char* path, uint64_t max_bytes, skr_blob_fn fn,
                     void* user);
  skr_status blobPut(uint16_t chan_id, const char* path, const void* data, size_t size,
                     skr_blob_fn fn, void* user);
  skr_status blobList(uint16_t chan_id, const char* dir, skr_blob_fn fn, void* user);
  skr_status blobDo(uint16_t chan_id, skr_blob_op op, const char* path, skr_blob_fn fn, void* user);
  skr_status syncPulse(uint16_t chan_id);
  skr_status syncFollow(const char* name, uint32_t every, uint32_t flags, skr_sync_fn fn,
                        void* user, skr_sub_handle* handle_out);
  skr_status syncUnfollow(skr_sub_handle handle);
  skr_status syncDone(skr_sub_handle handle, uint64_t seq);
  // Physical mode (ABI 1.7); `loop` is the hub's main loop (the paths' sockets and ticks).
  skr_status offerPaths(Loop& loop, uint16_t chan_id, const skr_path_options* options);
  skr_status publishBegin(uint16_t chan_id, void** slot_out, size_t* capacity_out);
  skr_status publishCommit(uint16_t chan_id, size_t size, int64_t capture_ns);

  // A module on its own thread (ABI 1.10): from now on its data, subscriber, request, response
  // and channel-watch callbacks are copied and posted to `module_loop`, each run there only if
  // what it belongs to (the subscription, channel, watch, this flow) still exists by then.
  void deliverOn(Loop& module_loop);

 private:
  struct Owned {
    skr_subscribers_fn on_subscribers;
    skr_request_fn on_request;
    void* user;
    skr_sub_handle key = 0;  // its callbacks' key in live_
  };
  // The registrations whose callbacks may still run on the module's thread (deliverOn).
  struct Live {
    std::mutex mutex;
    std::unordered_set<skr_sub_handle> keys;  // 0: this flow
    std::atomic<size_t> behind{0};            // data posted to the module's thread, not run yet
    [[nodiscard]] bool has(skr_sub_handle key) {
      std::lock_guard lock(mutex);
      return keys.count(key) != 0;
    }
    void add(skr_sub_handle key) {
      std::lock_guard lock(mutex);
      keys.insert(key);
    }
    void remove(skr_sub_handle key) {
      std::lock_guard lock(mutex);
      keys.erase(key);
    }
  };
  // Runs `call` on the module's thread if `key` is still live then (deliverOn). `bytes`: the data
  // it carries, counted in Live::behind until it ran.
  void deliver(skr_sub_handle key, std::function<void()> call, size_t bytes = 0);
  // Whether a message of `chan_id` of `bytes` may still be posted to the module's thread
  // (kMaxBehindBytes); else it is dropped, counted (LocalClient::dropped) and logged
  // (MODULE-BEHIND, at most once a second, with the count since the line before).
  bool roomFor(uint16_t chan_id, size_t bytes);
  void live(skr_sub_handle key) {
    if (live_) live_->add(key);
  }
  void gone(skr_sub_handle key) {
    if (live_) live_->remove(key);
  }
  struct Sub {
    skr_sub_handle handle;
    std::string name;
    uint16_t chan_id;  // 0 while the channel does not exist
    skr_data_fn fn;
    void* user;
  };
  struct Follow {
    skr_sub_handle handle;
    std::string name;
    uint16_t chan_id;  // 0 while the source does not exist
    uint32_t flags;
    skr_sync_fn fn;
    void* user;
  };
  struct ChannelWatch {
    skr_sub_handle handle;
    skr_channel_fn fn;
    void* user;
  };
  struct Pending {
    uint32_t tag;
    skr_response_fn fn;
    void* user;
  };

  skr_status fail(const std::string& what, const Error& error) const;
  [[nodiscard]] bool isWatching(skr_sub_handle handle) const;

  std::string name_;
  std::unique_ptr<flow::LocalClient> client_;
  std::unordered_map<uint16_t, Owned> owned_;
  std::optional<Owned> creating_;  // callbacks of the channel being created
  std::vector<Sub> subs_;
  std::vector<Follow> follows_;
  std::vector<ChannelWatch> channel_watches_;
  std::map<skr_sub_handle, uint64_t> db_watches_;  // the LocalClient's watch ids
  std::map<uint32_t, Pending> pending_;            // by the internal tag given to the server
  uint32_t next_tag_ = 1;
  // Barriers not answered yet, by number; the destructor answers them SKR_ERR_BAD_STATE. The
  // store's answer finds them through `alive_`, which dies with this object.
  std::map<uint64_t, std::pair<skr_done_fn, void*>> syncs_;
  uint64_t next_sync_ = 1;
  // Blob calls not answered yet, by number; answered SKR_ERR_BAD_STATE when the module stops.
  std::map<uint64_t, std::pair<skr_blob_fn, void*>> blobs_;
  uint64_t next_blob_ = 1;
  // Registers a blob call's answer; the function answers it once, if the module is still there.
  struct BlobAnswer {
    std::weak_ptr<ModuleFlow*> alive;
    uint64_t id;
    void operator()(skr_status status, std::string_view data, uint64_t version) const;
  };
  BlobAnswer expectBlob(skr_blob_fn fn, void* user);
  // The status for an immediate refusal, after the registered answer is dropped.
  skr_status refuseBlob(const BlobAnswer& a, const std::string& what, const Error& error);
  std::shared_ptr<ModuleFlow*> alive_ = std::make_shared<ModuleFlow*>(this);
  // Physical mode: made by the first offerPaths, ticked each second on `paths_loop_`.
  std::unique_ptr<flow::phys::Paths> paths_;
  Loop* paths_loop_ = nullptr;
  TickId paths_tick_ = 0;
  uint32_t next_path_tag_ = 1;
  bool offered_ = false;              // the last serve() reached the hub
  std::optional<Error> offer_error_;  // and what the hub said
  std::map<uint16_t, size_t> begun_;  // publish_begin's slot size, by channel
  skr_sub_handle next_handle_ = 1;
  Loop* deliver_loop_ = nullptr;  // deliverOn's
  std::shared_ptr<Live> live_;
  uint64_t behind_dropped_ = 0;  // messages dropped since the last MODULE-BEHIND line
  Nanos behind_logged_ = 0;      // when that line was written
};

}  // namespace skr
