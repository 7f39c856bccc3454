// SPDX-License-Identifier: Apache-2.0
// Replica: a channel mirrored as a local channel of another name (docs/hub-links.md,
// "Replicas"): typically a linked hub's camera as a local one. An Endpoint that owns
// "<user>.<short_name>", subscribes to its source while the replica has subscribers, republishes
// each payload once, and copies the source's mime type and properties. Asked by a satellite
// (REPLICATE_CHANNEL: it lives as long as that flow) or by the config (as long as the hub).
// Main loop thread only.
#pragma once

#include "endpoint.h"

#include <skrobot/hub/flow/server.h>

#include <cstdint>
#include <string>

namespace skr::flow {

struct Hub;

class Replica final : public Endpoint {
 public:
  // `requester`: the endpoint whose flow it lives with (0: the config's, the hub's lifetime).
  Replica(Hub& hub, std::string owner_user, std::string short_name, std::string source,
          uint32_t requester, std::shared_ptr<const AccessRules> rules = nullptr);
  ~Replica() override;  // its channel goes, everyone is told
  Replica(const Replica&) = delete;
  Replica& operator=(const Replica&) = delete;
  Replica(Replica&&) = delete;
  Replica& operator=(Replica&&) = delete;

  // Looks for the source now (later, it appears through onChannelAdded).
  void start();
  [[nodiscard]] const std::string& ownerUser() const noexcept { return owner_user_; }
  [[nodiscard]] const std::string& shortName() const noexcept { return short_name_; }
  [[nodiscard]] uint32_t requester() const noexcept { return requester_; }

  [[nodiscard]] bool receivesEvents() const override { return true; }
  [[nodiscard]] bool congested() const override { return false; }
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] const char* kind() const override { return "replica"; }
  void onData(const Channel& ch, std::string_view payload) override;
  void onSubscribers(const Channel& ch, bool first) override;
  void onRequest(const Channel&, uint64_t, const std::string&, const std::string&,
                 const Variant&) override {}
  void onResponse(uint16_t, uint32_t, bool, ErrorCode, const Variant&) override {}
  void onChannelAdded(const Channel& ch, uint32_t tag) override;
  void onChannelRemoved(const Channel& ch) override;
  void onChannelHeader(const Channel& ch) override;
  void onError(Code, uint32_t, uint16_t, ErrorCode, const std::string&) override {}
  void onDbChanged(const std::string&) override {}

 private:
  void attach(const Channel& source);
  void subscribeSource();
  [[nodiscard]] Variant propsOf(const Channel& source) const;

  Hub& hub_;
  std::string owner_user_, short_name_, source_;
  uint32_t requester_ = 0;
  uint16_t source_id_ = 0, local_id_ = 0;
};

}  // namespace skr::flow
