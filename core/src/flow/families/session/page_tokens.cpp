// SPDX-License-Identifier: Apache-2.0
// Page tokens (page_tokens.h).
#include "families/session/page_tokens.h"

#include <sodium.h>

#include <algorithm>
#include <cstring>

namespace skr::flow {

PageTokens::PageTokens(std::string account, Nanos ttl_ns)
    : account_(std::move(account)), ttl_ns_(ttl_ns) {
  randombytes_buf(key_.data(), key_.size());
}

size_t PageTokens::HashOf::operator()(const Hash& h) const noexcept {
  size_t v;
  std::memcpy(&v, h.data(), sizeof v);  // already a keyed hash: any bytes spread well
  return v;
}

PageTokens::Hash PageTokens::hash(std::string_view token) const {
  Hash h;
  crypto_generichash(h.data(), h.size(), reinterpret_cast<const unsigned char*>(token.data()),
                     token.size(), key_.data(), key_.size());
  return h;
}

void PageTokens::prune(Nanos now) {
  std::erase_if(tokens_, [now](const auto& e) { return e.second.expires <= now; });
  // An address whose bucket has refilled is like one never seen.
  std::erase_if(buckets_, [now](const auto& b) {
    return now - b.second.last >= static_cast<Nanos>(kBurst) * kRefillInterval;
  });
}

Result<PageTokens::Issued> PageTokens::issue(const std::string& address, Nanos now) {
  if (tokens_.size() >= kMaxLive || buckets_.size() >= kMaxAddresses) prune(now);
  auto it = buckets_.find(address);
  if (it == buckets_.end()) {
    if (buckets_.size() >= kMaxAddresses) {
      return makeError(Errc::limit_exceeded, "too many addresses asking for page tokens");
    }
    it = buckets_.emplace(address, Bucket{static_cast<double>(kBurst), now}).first;
  }
  Bucket& b = it->second;
  b.tokens =
      std::min(static_cast<double>(kBurst),
               b.tokens + static_cast<double>(now - b.last) / static_cast<double>(kRefillInterval));
  b.last = now;
  if (b.tokens < 1) {
    return makeError(Errc::limit_exceeded, "page tokens asked for too often from " + address);
  }
  if (tokens_.size() >= kMaxLive) {
    return makeError(Errc::limit_exceeded,
                     std::to_string(kMaxLive) + " page tokens are live already");
  }
  b.tokens -= 1;
  unsigned char raw[32];
  randombytes_buf(raw, sizeof raw);
  char text[sodium_base64_ENCODED_LEN(32, sodium_base64_VARIANT_URLSAFE_NO_PADDING)];
  sodium_bin2base64(text, sizeof text, raw, sizeof raw, sodium_base64_VARIANT_URLSAFE_NO_PADDING);
  sodium_memzero(raw, sizeof raw);
  Issued out{text, account_, ttl_ns_};
  tokens_[hash(out.token)] = Entry{address, now + ttl_ns_};
  return out;
}

std::optional<std::string> PageTokens::redeem(std::string_view token, const std::string& address,
                                              Nanos now, std::string* reason) {
  const auto say = [reason](const char* why) {
    if (reason != nullptr) *reason = why;
    return std::nullopt;
  };
  if (token.size() != 43) return say("not a page token");
  const auto it = tokens_.find(hash(token));
  if (it == tokens_.end()) return say("unknown page token");
  if (it->second.expires <= now) {
    tokens_.erase(it);
    return say("expired page token");
  }
  if (it->second.address != address) return say("page token fetched from another address");
  return account_;
}

}  // namespace skr::flow
