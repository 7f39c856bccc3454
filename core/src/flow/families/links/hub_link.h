// SPDX-License-Identifier: Apache-2.0
// HubLink: this hub's link to another (docs/hub-links.md). A satellite of the far hub, on this
// hub's loop (skr::sat::Satellite: reconnection with backoff, subscriptions by name, request
// timeouts), and an Endpoint here that owns the far hub's channels as "<hub>/<user>.<name>".
// Data crosses only while someone here subscribes, a sync source's pulses only while someone here
// follows it; service requests are passed on with what is left of their time. Main loop thread
// only.
#pragma once

#include "endpoint.h"
#include "families/blobs/blob_store.h"

#include <skrobot/hub/flow/server.h>  // HubLinkOptions
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/messages.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace skr::sat {
class Satellite;
struct BlobChange;
struct SyncPulse;
}  // namespace skr::sat

namespace skr::flow {

class FarBlobs;
struct Hub;

class HubLink final : public Endpoint {
 public:
  HubLink(Hub& hub, HubLinkOptions options);
  // Removes the remote channels (everyone is told) and closes the connection.
  ~HubLink() override;
  HubLink(const HubLink&) = delete;
  HubLink& operator=(const HubLink&) = delete;
  HubLink(HubLink&&) = delete;
  HubLink& operator=(HubLink&&) = delete;

  void start();
  [[nodiscard]] const HubLinkOptions& options() const noexcept { return opt_; }
  // Once a second (from the server's sweep): a clock probe every few seconds, and the link's
  // database "_link.<name>" (state, channels, traffic, round trip, clock offset).
  void everySecond(Nanos now);
  // Another link dropped: takes the far channels this one offers that nobody shows any more.
  void offerAgain();
  // Open, and the far hub said it is the one the config names.
  [[nodiscard]] bool up() const noexcept { return up_; }
  // --- one connection for two hubs that list each other (hub_link_shared.cpp)
  // The far hub linked in on connection `c` (HUB_LINK_HELLO): refused (already_exists) while
  // this link's own connection is up and this hub's name sorts first; else `c` becomes the link
  // (this one stops dialling) and the far hub offers its channels on it.
  [[nodiscard]] Result<void> adopt(const Endpoint& c);
  [[nodiscard]] uint32_t sharedConnection() const noexcept { return shared_; }
  // The shared connection closed: dial again (at once when this hub's name sorts first).
  void released();

  // Up, and `hub` is the far hub or a hub whose channels come through it.
  [[nodiscard]] bool reaches(std::string_view hub) const;
  // Reads database `db` of the far hub ("<hub>/<name>" for a hub beyond it) as the link's
  // account; `done` gets the value or the far hub's error (io_error when the link drops first).
  void readDatabase(const std::string& db, msg::DbReadWhat what, const std::string& key,
                    std::function<void(Result<Variant>)> done);

  // --- the far hub's blob channels shown here: reads passed on (far_blobs.h) for the connection
  // `reader` here, which the blobs room checked against its rules; the far hub checks the link's
  // account. not_found when `ch` is not one of this link's.
  void blobList(uint32_t reader, const Channel& ch, std::string dir,
                std::function<void(Result<Variant>)> done);
  void blobGet(uint32_t reader, const Channel& ch, std::string path, uint64_t version,
               uint64_t offset, uint32_t max_bytes, size_t head_room,
               std::function<void(Result<BlobStore::Read>)> done);
  // The connection `reader` left: its connection to the far hub closes.
  void forgetReader(uint32_t reader);

  // --- Endpoint: what happens here to the channels it owns
  [[nodiscard]] bool receivesEvents() const override { return true; }
  [[nodiscard]] bool congested() const override;
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] const char* kind() const override { return "link"; }
  void onData(const Channel& ch, std::string_view payload) override;
  void onSubscribers(const Channel& ch, bool first) override;
  void onFollowers(const Channel& ch, bool first) override;
  void onRequest(const Channel& ch, uint64_t request, const std::string& command,
                 const std::string& requester, const Variant& value) override;
  void onResponse(uint16_t chan_id, uint32_t tag, bool sync, ErrorCode error,
                  const Variant& value) override;
  void onChannelAdded(const Channel& ch, uint32_t tag) override;
  void onChannelRemoved(const Channel& ch) override;
  void onChannelHeader(const Channel& ch) override;
  void onError(Code command, uint32_t tag, uint16_t chan_id, ErrorCode error,
               const std::string& message) override;
  void onDbChanged(const std::string&) override {}

 private:
  struct Remote {
    uint16_t remote_id = 0;  // on the far hub
    std::string remote_name;
  };
  void opened();
  void lost(const std::string& why);
  void added(const msg::ChannelInfo& info);
  void removed(uint16_t remote_id);
  // One of the far channels shown here was removed, whoever removed it (the far hub, a shorter
  // route, the link dropping, an administrator): what we hold over there for it goes too.
  void shownNoMore(const Channel& ch);
  void changed(const msg::ChannelInfo& info);
  void data(uint16_t remote_id, std::string_view payload);
  void farPulse(const sat::SyncPulse& p);
  void timeSample(int64_t round_trip_ns, int64_t offset_ns);
  void writeDb();
  void dropAll();
  // Offering this hub's channels on our connection (the far hub sent EV_LINK_WANTED).
  void offerAll();
  void offer(const Channel& ch);
  [[nodiscard]] bool offered(const msg::ChannelInfo& info);  // made over there: keep its id
  void farDemand(uint16_t far_id, bool first);
  void farRequest(const msg::EvServiceRequest& r);
  void farBlobChanged(const sat::BlobChange& b);
  // The far channel behind the local one `ch`, or not_found; and the reads' worker, made on
  // first use.
  Result<uint16_t> farBlobId(const Channel& ch) const;
  FarBlobs& farBlobs();
  void stopOffering();

  Hub& hub_;
  HubLinkOptions opt_;
  std::unique_ptr<sat::Satellite> sat_;
  std::unique_ptr<FarBlobs> blobs_;
  std::unordered_set<uint32_t> readers_;  // connections here that read far blobs
  bool up_ = false;
  bool limit_logged_ = false;
  std::string state_ = "connecting";
  std::string since_;  // UTC of the last change of state
  std::string db_;     // "_link.<name>"
  uint64_t requests_ = 0;
  Nanos next_probe_ = 0;
  // The best (shortest round trip) of the last clock samples, as NTP's clock filter keeps.
  struct Sample {
    int64_t round_trip_ns = 0, offset_ns = 0;
  };
  std::vector<Sample> samples_;
  std::unordered_map<uint16_t, uint16_t> by_remote_;  // far id -> local id
  std::unordered_map<uint16_t, Remote> by_local_;     // local id -> far channel
  // A shared link: the far hub's connection here (0: none), and when to dial again.
  uint32_t shared_ = 0;
  Nanos redial_at_ = 0;
  // What we offer over there: far name -> local id until it is made, then both ways.
  bool offering_ = false;
  struct Offer {
    uint16_t local = 0;
    uint32_t tag = 0;
    std::string name;  // here
  };
  std::unordered_map<std::string, Offer> offers_;
  std::unordered_map<uint16_t, uint16_t> offered_far_;                // local id -> far id
  std::unordered_map<uint16_t, uint16_t> offered_;                    // far id -> local id
  std::unordered_map<uint32_t, msg::EvServiceRequest> far_requests_;  // our tag -> far request
  uint32_t next_tag_ = 1;
};

}  // namespace skr::flow
