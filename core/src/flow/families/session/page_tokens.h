// SPDX-License-Identifier: Apache-2.0
// Page tokens (docs/security.md, "The web port"): what a page served by the hub logs in with over
// WebSocket, fetched with POST /skrobot/token. A token is 32 random bytes in base64url; the hub
// keeps only a keyed hash of it (the key random per hub run), with the account it logs in as,
// its expiry and the peer address that fetched it. A token may be used for any number of logins
// until it expires, from that address only (a page opens its flow and synchronous connections).
// At most kMaxLive live tokens; each address may fetch kBurst at once, then one per
// kRefillInterval (a page reloads; a script that hammers the port gets limit_exceeded).
// Main loop thread only.
#pragma once

#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/result.h>

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

namespace skr::flow {

class PageTokens {
 public:
  static constexpr size_t kMaxLive = 4096;
  static constexpr size_t kBurst = 16;
  static constexpr Nanos kRefillInterval = 250 * kNsPerMs;
  static constexpr size_t kMaxAddresses = 4096;

  // Tokens log in as `account` and live `ttl_ns`.
  PageTokens(std::string account, Nanos ttl_ns);

  struct Issued {
    std::string token;  // base64url, no padding (43 characters)
    std::string account;
    Nanos ttl_ns = 0;
  };
  // A new token for a page fetched from `address` (a peer's numeric address).
  // Errc::limit_exceeded when that address asked too often or kMaxLive tokens are live.
  [[nodiscard]] Result<Issued> issue(const std::string& address, Nanos now);
  // The account `token` logs in as, when it is live and used from the address that fetched
  // it; nullopt otherwise (unknown, expired, another address), with why in `reason`.
  [[nodiscard]] std::optional<std::string> redeem(std::string_view token,
                                                  const std::string& address, Nanos now,
                                                  std::string* reason = nullptr);
  [[nodiscard]] size_t live() const noexcept { return tokens_.size(); }

 private:
  using Hash = std::array<unsigned char, 32>;
  struct HashOf {
    size_t operator()(const Hash& h) const noexcept;
  };
  struct Entry {
    std::string address;
    Nanos expires = 0;
  };
  struct Bucket {
    double tokens = 0;
    Nanos last = 0;
  };
  [[nodiscard]] Hash hash(std::string_view token) const;
  void prune(Nanos now);

  std::string account_;
  Nanos ttl_ns_;
  std::array<unsigned char, 32> key_{};
  std::unordered_map<Hash, Entry, HashOf> tokens_;
  std::unordered_map<std::string, Bucket> buckets_;  // per address
};

}  // namespace skr::flow
